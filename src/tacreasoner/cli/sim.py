"""``tacreasoner simulate`` and ``sim-preview``: DynTAC-Sim clips and a look at them."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from tacreasoner.cli.app import Seed, Workers, app, cli_errors, comma_list, console

OutDir = Annotated[Path, typer.Option("--out", help="Dataset directory (an existing one is resumed).")]
Objects = Annotated[int, typer.Option("--objects", help="Objects: the 15 named ones, then procedural.")]
Repeats = Annotated[int, typer.Option("--repeats", help="Clips per object and sensor (slide, rotate, …).")]
Overwrite = Annotated[bool, typer.Option("--overwrite", help="Discard finished clips instead of resuming.")]


@app.command()
@cli_errors
def simulate(
    out: OutDir,
    objects: Objects = 100,
    repeats: Repeats = 5,
    sensors: Annotated[str, typer.Option("--sensors", help="Comma-separated: mini, digit, tac3d; NAME@FPS; "
                                                           "mini+markers; NAME+varied (each clip its own look), "
                                                           "NAME+varied50 (half the clips).")
                       ] = "mini",
    seed: Seed = 0,
    workers: Workers = None,
    overwrite: Overwrite = False,
) -> None:
    """Generate a DynTAC-Sim dataset: mp4 clips + per-frame ground truth in manifest.jsonl (resumable)."""
    from tacreasoner.sim.run import run_simulation

    summary = run_simulation(out, objects, repeats, comma_list(sensors), seed, workers, overwrite)
    console.print(summary.text())



@app.command("sim-preview")
@cli_errors
def sim_preview(
    out: Annotated[Path, typer.Option("--out", help="Contact sheet PNG (plot: <stem>_signals.png).")],
    dataset: Annotated[Path | None, typer.Option("--dataset", help="Preview a clip of this dataset.")] = None,
    clip: Annotated[str | None, typer.Option(
        "--clip", help="Clip id in the dataset, e.g. mini/apple_real_0 (default: the first clip).")] = None,
    object_name: Annotated[str | None, typer.Option(
        "--object", help="Catalogue object to simulate (default: apple_real).")] = None,
    sensor: Annotated[str | None, typer.Option("--sensor", help="Sensor style (default: mini).")] = None,
    action: Annotated[str | None, typer.Option("--action", help="slide or rotate (default: slide).")] = None,
    seed: Annotated[int | None, typer.Option("--seed", help="Master seed (default: 0).")] = None,
) -> None:
    """Write a contact sheet and a ground-truth plot for one clip (simulated now, or from a dataset)."""
    from tacreasoner.sim.generate import read_manifest
    from tacreasoner.sim.preview import preview_from_dataset, simulate_catalogue_clip, write_preview

    if dataset is None:
        if clip is not None:
            raise ValueError("--clip needs --dataset")
        preview = simulate_catalogue_clip(object_name or "apple_real", sensor or "mini", action or "slide",
                                          seed or 0)
    else:
        options = {"--object": object_name, "--sensor": sensor, "--action": action, "--seed": seed}
        given = [name for name, value in options.items() if value is not None]
        if given:
            raise ValueError(f"{', '.join(given)} cannot be combined with --dataset (the clip fixes them)")
        clip_id = clip or read_manifest(dataset)[0]["clip_id"]
        preview = preview_from_dataset(dataset, clip_id)
    for path in write_preview(preview, out):
        console.print(str(path))
