"""The simulator's renderer against the one at an earlier commit: identical frames? how much faster?

Loads ``src/tacreasoner/sim/render.py`` as it was at ``--ref`` (via ``git show``) next to the current one and
renders the same trajectories and scenes with both, alternating which goes first, in one process at one
thread. Frames are compared byte for byte, so a speed-up that changes the data shows up as "identical: no".

    python benchmarks/render_compare.py --ref e897228 [--objects 8 --sensors mini,digit,tac3d --rounds 3]
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import header_md, md_table, publish, stamp
from tacreasoner.sim import render as current
from tacreasoner.sim.generate import action_for_repeat, clip_seed, simulate_trajectory
from tacreasoner.sim.materials import build_object_set
from tacreasoner.sim.sensors import get_sensor

REPO = Path(__file__).resolve().parents[1]


def renderer_at(ref: str, tmp: Path):
    source = subprocess.run(["git", "show", f"{ref}:src/tacreasoner/sim/render.py"], cwd=REPO, check=True,
                            capture_output=True, text=True).stdout
    path = tmp / "render_at_ref.py"
    path.write_text(source)
    spec = importlib.util.spec_from_file_location("render_at_ref", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the class is built
    spec.loader.exec_module(module)
    return module


def render(module, traj, scene) -> tuple[float, list[np.ndarray]]:
    start = time.perf_counter()
    chunks = list(module.render_frames(traj, scene))
    return time.perf_counter() - start, chunks


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--ref", required=True, help="Commit whose renderer is the baseline.")
    ap.add_argument("--objects", type=int, default=8)
    ap.add_argument("--sensors", default="mini,digit,tac3d")
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        baseline = renderer_at(args.ref, Path(tmp))
    cases = []
    for si, sensor in enumerate(args.sensors.split(",")):
        style = get_sensor(sensor)
        for oi, material in enumerate(build_object_set(args.objects, 0)):
            repeat = oi % 5
            rng = np.random.default_rng(np.random.SeedSequence(clip_seed(0, oi, repeat, si)))
            traj = simulate_trajectory(material, style, action_for_repeat(repeat), rng)
            scene = current.RenderScene.build(style, material, float(np.abs(traj.object_shift_mm).max()) + 1.0, rng)
            cases.append((sensor, traj, scene))
    seconds: dict[str, dict[str, float]] = {}
    frames: dict[str, int] = {}
    identical = True
    for r in range(args.rounds):
        for sensor, traj, scene in cases:
            order = [("baseline", baseline), ("current", current)]
            outputs = {}
            for name, module in (order if r % 2 == 0 else order[::-1]):
                took, outputs[name] = render(module, traj, scene)
                seconds.setdefault(sensor, {}).setdefault(name, 0.0)
                seconds[sensor][name] += took
            identical &= all(np.array_equal(a, b) for a, b in zip(outputs["baseline"], outputs["current"], strict=True))
            frames[sensor] = frames.get(sensor, 0) + len(traj)
    rows, payload = [], {}
    for sensor, by_name in seconds.items():
        ratio = by_name["current"] / by_name["baseline"]
        per = {k: 1000 * v / frames[sensor] for k, v in by_name.items()}
        rows.append([sensor, args.objects, frames[sensor] // args.rounds, f"{per['baseline']:.2f}",
                     f"{per['current']:.2f}", f"**{ratio:.2f}×**"])
        payload[sensor] = {"ms_per_frame": per, "time_ratio_current_vs_baseline": ratio}
    total = sum(s["current"] for s in seconds.values()) / sum(s["baseline"] for s in seconds.values())
    info = stamp()
    md = header_md(f"Renderer: current vs commit {args.ref}", info)
    md += (f"Rendering only (no H.264 encoding), one process, the same {len(cases)} trajectories and scenes for both, "
           f"{args.rounds} rounds alternating which goes first. Frames identical byte for byte: "
           f"**{'yes' if identical else 'NO'}**. Time of the current renderer relative to {args.ref}'s: "
           f"**{total:.2f}×** over all clips.\n\n")
    md += md_table(["sensor", "clips", "frames", f"{args.ref} (ms/frame)", "current (ms/frame)", "time ratio"], rows)
    publish("render_compare", {**info, "ref": args.ref, "identical": bool(identical), "time_ratio": total,
                               "sensors": payload}, md)


if __name__ == "__main__":
    main()
