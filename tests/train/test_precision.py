"""``runtime.mixed_precision: auto`` picks bf16 only where the CPU computes it natively."""

from __future__ import annotations

from tacreasoner.train.precision import bf16_supported, resolve_mixed_precision


def test_bf16_is_chosen_only_where_the_cpu_has_native_bf16() -> None:
    """oneDNN calls bf16 supported on every AVX-512 CPU, where it is emulated and several times slower than float32:
    the CPU's flags decide."""
    assert not bf16_supported("processor: 0\nflags\t\t: fpu sse avx2 avx512f avx512bw avx512_vnni\n")
    assert bf16_supported("processor: 0\nflags\t\t: fpu avx512f avx512_bf16\n")
    assert bf16_supported("processor: 0\nflags\t\t: fpu amx_bf16 amx_tile\n")
    assert bf16_supported("processor\t: 0\nFeatures\t: fp asimd sve bf16 i8mm\n")
    assert not bf16_supported("processor\t: 0\nFeatures\t: fp asimd\n")


def test_an_explicit_setting_is_kept_and_auto_is_resolved() -> None:
    assert resolve_mixed_precision("no") == "no" and resolve_mixed_precision("bf16") == "bf16"
    assert resolve_mixed_precision("auto") in ("bf16", "no")


def test_a_user_is_told_when_a_cpu_without_native_bf16_trains_in_float32(monkeypatch) -> None:
    """The quickstart's timings are for a CPU with bf16; one without trains in float32, about 2x slower."""
    from tacreasoner.train import precision

    monkeypatch.setattr(precision.torch.cuda, "is_available", lambda: False)
    monkeypatch.setattr(precision, "bf16_supported", lambda: False)
    assert precision.describe_precision("auto").startswith("float32: this CPU lists no native bf16")
    assert precision.describe_precision("no") == "float32 on this CPU"  # asked for: no excuse needed
    monkeypatch.setattr(precision, "bf16_supported", lambda: True)
    assert precision.describe_precision("auto") == "bf16 autocast on this CPU (native bf16)"
    assert precision.describe_precision("bf16") == "bf16 autocast on this CPU"
