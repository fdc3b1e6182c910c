"""Does simulated GelSight Mini look like the real thing? Colour/contrast statistics, side by side.

Real: PhysiCLeAR GelSight Mini clips from ``../shared/data/physiclear`` (not redistributed; only
statistics are written). Simulated: DynTAC-Sim ``mini`` clips of the catalogue + procedural objects.
For each clip: the no-contact frame (background) and the frame of strongest contact.

    python benchmarks/sim_realism.py [--real-dir ../shared/data/physiclear --clips 60 --sensors mini mini+physiclear]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import RESULTS, header_md, md_table, publish, stamp
from tacreasoner.data.cues import frame_signals
from tacreasoner.sim.generate import action_for_repeat, simulate_clip
from tacreasoner.sim.materials import build_object_set
from tacreasoner.video_io import read_video

DEFAULT_REAL = Path(__file__).resolve().parents[2] / "shared" / "data" / "physiclear"


def _clip_stats(frames: np.ndarray) -> tuple[dict, np.ndarray, np.ndarray]:
    s = frame_signals(frames)
    peak = int(np.argmax(s.intensity))
    bg = frames[0].astype(np.float32)
    top = frames[peak].astype(np.float32)
    diff = np.abs(top - bg).mean(-1)
    corners = np.asarray([bg[:30, :30].mean(), bg[-30:, -30:].mean(), bg[:30, -30:].mean(), bg[-30:, :30].mean()])
    stats = {
        "bg_mean_r": bg[..., 0].mean(), "bg_mean_g": bg[..., 1].mean(), "bg_mean_b": bg[..., 2].mean(),
        "bg_std_r": bg[..., 0].std(), "bg_std_g": bg[..., 1].std(), "bg_std_b": bg[..., 2].std(),
        "bg_centre_minus_corner": float(bg[80:160, 110:210].mean() - corners.mean()),
        "noise_std": float((frames[1].astype(np.float32) - bg).std()),
        "peak_mean_abs_diff": float(diff.mean()),
        "peak_p99_abs_diff": float(np.percentile(diff, 99)),
        "peak_contact_area": float(s.area[peak]),
        # the pace of contact (issue 28's second calibration target; its first, the contact signal, is
        # peak_mean_abs_diff): the mean |frame − previous frame|, grey levels averaged over pixels and colours
        "frame_change": float(np.abs(np.diff(frames.astype(np.float32), axis=0)).mean()),
    }
    return {k: float(v) for k, v in stats.items()}, frames[0], frames[peak]


def _summary(rows: list[dict]) -> dict:
    keys = rows[0].keys()
    return {k: {"mean": float(np.mean([r[k] for r in rows])), "std": float(np.std([r[k] for r in rows]))}
            for k in keys}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--real-dir", type=Path, default=DEFAULT_REAL)
    ap.add_argument("--clips", type=int, default=60)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sensors", nargs="+", default=["mini", "mini+physiclear"],
                    help="simulated sensor styles, each a column (the first one is drawn in the figure)")
    args = ap.parse_args()
    videos = sorted((args.real_dir / "videos").glob("*.mov"))
    if not videos:
        raise SystemExit(f"no PhysiCLeAR videos under {args.real_dir}/videos: nothing to compare against")
    step = max(1, len(videos) // args.clips)
    real_rows, real_examples = [], []
    for path in videos[::step][: args.clips]:
        frames, fps = read_video(path)
        if fps < 20:  # a few PhysiCLeAR clips are 10 fps; keep the 25 fps majority comparable
            continue
        stats, bg, top = _clip_stats(frames)
        real_rows.append(stats)
        real_examples.append((path.stem, bg, top))

    objects = build_object_set(max(args.clips, 15), args.seed)
    sims: dict[str, dict] = {}
    sim_examples: list = []
    for sensor in args.sensors:
        rows = []
        for i, material in enumerate(objects[: args.clips]):
            clip = simulate_clip(material, sensor, action_for_repeat(i), seed=(args.seed, i, 0, 0))
            stats, bg, top = _clip_stats(clip.frames)
            rows.append(stats)
            if sensor == args.sensors[0]:
                sim_examples.append((material.name, bg, top))
        sims[sensor] = _summary(rows)

    real = _summary(real_rows)
    _figure(real_examples, sim_examples, RESULTS / "sim_realism.png")
    info = stamp()
    payload = {**info, "settings": {k: str(v) for k, v in vars(args).items()}, "n_real": len(real_rows),
               "n_sim": len(objects[: args.clips]), "real": real, "sim": sims[args.sensors[0]], "sims": sims}

    def cell(summary: dict, key: str) -> str:
        if key == "peak_contact_area":
            return f"{summary[key]['mean']:.3f}"
        return f"{summary[key]['mean']:.1f} ± {summary[key]['std']:.1f}"

    rows = [[k if k != "peak_contact_area" else "peak_contact_area (fraction)", cell(real, k),
             *(cell(sims[sensor], k) for sensor in args.sensors)] for k in real]
    md = header_md("DynTAC-Sim realism: simulated GelSight Mini vs real PhysiCLeAR frames", info)
    md += (f"{len(real_rows)} real PhysiCLeAR clips (25 fps) vs {len(objects[: args.clips])} simulated clips per "
           "sensor style. Statistics of the no-contact frame (bg_*) and of the frame of strongest contact (peak_*), "
           "in 8-bit grey levels, mean ± std over clips. peak_mean_abs_diff is the contact signal (the mean "
           "|frame − first frame| at the clip's strongest contact); frame_change is the clip's mean |frame − previous "
           "frame|. `mini+physiclear` is the Mini with its contact shading scaled to PhysiCLeAR's contact signal "
           "(`tacreasoner simulate --sensors mini+physiclear`; src/tacreasoner/sim/sensors.py).\n\n")
    md += md_table(["statistic", "real (PhysiCLeAR)", *(f"simulated `{sensor}`" for sensor in args.sensors)], rows)
    md += (f"\n![real vs simulated](sim_realism.png)\n\n(The figure's simulated rows are `{args.sensors[0]}`.) What is "
           "not matched: real clips are hand-held presses of everyday objects, many of them small or edged (the "
           "imprint covers less of the gel), and the real gel shows dust, scratches and a non-uniform coating that "
           "the simulator only approximates.\n")
    publish("sim_realism", payload, md)


def _figure(real: list, sim: list, out: Path, n: int = 4) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(4, n, figsize=(3.2 * n, 9.6))
    for col in range(n):
        for row, (label, examples) in enumerate((("real", real), ("sim", sim))):
            name, bg, top = examples[(col * len(examples)) // n]
            axes[2 * row, col].imshow(bg)
            axes[2 * row, col].set_title(f"{label}: {name}\nno contact", fontsize=8)
            axes[2 * row + 1, col].imshow(top)
            axes[2 * row + 1, col].set_title(f"{label}: {name}\npeak contact", fontsize=8)
    for ax in axes.flat:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(out, dpi=55)
    plt.close(fig)


if __name__ == "__main__":
    main()
