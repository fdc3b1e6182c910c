"""Teacher configuration, the factory, usage counting and reply normalisation (no network, no model)."""

from __future__ import annotations

import threading

import pytest

from tacreasoner.cot.backends import (
    TeacherConfig,
    UsageMeter,
    cost_of,
    load_teacher_config,
    make_teacher,
    reply_to_output,
)
from tacreasoner.cot.schema import TeacherReply


def _one_line_error(excinfo: pytest.ExceptionInfo) -> str:
    message = str(excinfo.value)
    assert "\n" not in message
    return message


def test_defaults_are_valid_and_offline() -> None:
    config = TeacherConfig()
    assert config.backend == "rules"
    assert config.api_key_env == "OPENAI_API_KEY"


def test_unknown_keys_are_named() -> None:
    with pytest.raises(ValueError) as excinfo:
        TeacherConfig.from_dict({"backend": "openai", "model": "m", "temprature": 0.2, "max_token": 5})
    message = _one_line_error(excinfo)
    assert "temprature" in message and "max_token" in message


@pytest.mark.parametrize(("data", "needle"), [
    ({"backend": "anthropic"}, "unknown backend 'anthropic'"),
    ({"backend": "openai"}, "needs a model"),
    ({"backend": "hf", "model": " "}, "needs a model"),
    ({"backend": "openai", "model": "m", "base_url": "api.deepseek.com"}, "base_url"),
    ({"backend": "openai", "model": "m", "base_url": "ftp://host/v1"}, "base_url"),
    ({"concurrency": -1}, "concurrency"),
    ({"concurrency": 0}, "concurrency"),
    ({"concurrency": 2.5}, "concurrency"),
    ({"max_retries": -1}, "max_retries"),
    ({"timeout_s": 0}, "timeout_s"),
    ({"temperature": "hot"}, "temperature"),
    ({"temperature": float("nan")}, "temperature"),
    ({"max_tokens": 0}, "max_tokens"),
    ({"backoff_base_s": -0.1}, "backoff_base_s"),
    ({"price_per_1k_prompt": -1}, "price_per_1k_prompt"),
    ({"api_key_env": "MY KEY"}, "api_key_env"),
    ({"extra": [1, 2]}, "extra"),
])
def test_bad_settings_are_one_line_errors(data: dict, needle: str) -> None:
    with pytest.raises(ValueError) as excinfo:
        TeacherConfig.from_dict(data)
    assert needle in _one_line_error(excinfo)


def test_key_env_defaults_follow_the_endpoint() -> None:
    deepseek = TeacherConfig(backend="openai", model="deepseek-chat", base_url="https://api.deepseek.com")
    assert deepseek.api_key_env == "DEEPSEEK_API_KEY"
    local = TeacherConfig(backend="openai", model="qwen", base_url="http://127.0.0.1:8000/v1")
    assert local.api_key_env == "OPENAI_API_KEY"
    explicit = TeacherConfig(backend="openai", model="m", base_url="https://api.deepseek.com", api_key_env="MY_KEY")
    assert explicit.api_key_env == "MY_KEY"


def test_yaml_config_plain_and_nested(tmp_path) -> None:
    plain = tmp_path / "teacher.yaml"
    plain.write_text("backend: openai\nmodel: deepseek-reasoner\nbase_url: https://api.deepseek.com\n"
                     "concurrency: 16\nprice_per_1k_prompt: 0.00055\nextra:\n  top_p: 0.9\n")
    config = load_teacher_config(plain)
    assert config.model == "deepseek-reasoner" and config.concurrency == 16
    assert config.api_key_env == "DEEPSEEK_API_KEY"
    assert config.extra == {"top_p": 0.9}
    nested = tmp_path / "nested.yaml"
    nested.write_text("teacher:\n  backend: rules\n")
    assert load_teacher_config(nested).backend == "rules"


def test_yaml_errors_name_the_file(tmp_path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("backend: openai\nmodel: m\nconcurrenci: 4\n")
    with pytest.raises(ValueError) as excinfo:
        load_teacher_config(bad)
    message = _one_line_error(excinfo)
    assert "bad.yaml" in message and "concurrenci" in message
    listy = tmp_path / "list.yaml"
    listy.write_text("- backend: openai\n")
    with pytest.raises(ValueError, match="mapping"):
        load_teacher_config(listy)
    with pytest.raises(ValueError, match="cannot read"):
        load_teacher_config(tmp_path / "missing.yaml")


def test_make_teacher_without_key_names_the_env_var(monkeypatch) -> None:
    monkeypatch.delenv("DEEPSEEK_API_KEY", raising=False)
    with pytest.raises(ValueError) as excinfo:
        make_teacher({"backend": "openai", "model": "deepseek-chat", "base_url": "https://api.deepseek.com"})
    assert "DEEPSEEK_API_KEY" in _one_line_error(excinfo)
    monkeypatch.setenv("DEEPSEEK_API_KEY", "   ")
    with pytest.raises(ValueError, match="DEEPSEEK_API_KEY"):
        make_teacher({"backend": "openai", "model": "deepseek-chat", "base_url": "https://api.deepseek.com"})


def test_make_teacher_builds_an_openai_teacher_without_network(monkeypatch) -> None:
    monkeypatch.setenv("DEEPSEEK_API_KEY", "sk-test")
    teacher = make_teacher(TeacherConfig(backend="openai", model="deepseek-chat", base_url="https://api.deepseek.com"))
    assert (teacher.name, teacher.model) == ("openai", "deepseek-chat")


def test_make_teacher_rules() -> None:
    from tacreasoner.cot import rules
    teacher = make_teacher(TeacherConfig(backend="rules"))
    assert isinstance(teacher, rules.RulesTeacher)


def test_usage_meter_counts_across_threads() -> None:
    meter = UsageMeter()

    def work() -> None:
        for _ in range(500):
            meter.record_attempt("ok")
            meter.record_tokens(3, 2, 0.001)
        meter.record_attempt("429")
        meter.record_retry()

    threads = [threading.Thread(target=work) for _ in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    meter.record_failure()
    summary = meter.summary()
    assert summary["requests"] == 8 * 501
    assert summary["by_status"] == {"429": 8, "ok": 4000}
    assert summary["retries"] == 8 and summary["failures"] == 1
    assert summary["prompt_tokens"] == 12000 and summary["completion_tokens"] == 8000
    assert summary["cost_usd"] == pytest.approx(4.0)


def test_cost_uses_per_thousand_prices() -> None:
    config = TeacherConfig(price_per_1k_prompt=0.5, price_per_1k_completion=2.0)
    assert cost_of(config, 2000, 500) == pytest.approx(2.0)


@pytest.mark.parametrize(("text", "reasoning", "expected"), [
    ("<think>Pressing shows a wide contact.</think><answer>soft</answer>", None,
     ("Pressing shows a wide contact.", "soft")),
    ("Sure!\n<think>\n step 1 \n</think>\n<answer> the first object </answer>\n", None,
     ("step 1", "the first object")),
    ("<THINK>a</THINK><ANSWER>b</ANSWER>", None, ("a", "b")),
    ("soft", "The imprint grows fast during press.", ("The imprint grows fast during press.", "soft")),
    ("The object is soft.\n\nAnswer: soft", "Long hidden reasoning.",
     ("Long hidden reasoning.\n\nThe object is soft.", "soft")),
    ("<answer>soft</answer>", "Channel reasoning.", ("Channel reasoning.", "soft")),
    ("Press: big area. Hold: relaxes.\n<answer>soft</answer>", None, ("Press: big area. Hold: relaxes.", "soft")),
    ("<think>R1 style reasoning</think>\n\nsoft", None, ("R1 style reasoning", "soft")),
    ("<think>R1 style</think> Final answer: **soft**", None, ("R1 style", "soft")),
    ("During press the area grows; on release it recovers.\nAnswer: moderately deformable", None,
     ("During press the area grows; on release it recovers.", "moderately deformable")),
    ("Reasoning here. **Final Answer:** B", None, ("Reasoning here.", "B")),
    ("按压时接触面积增大。Answer\uff1a soft", None, ("按压时接触面积增大。", "soft")),
    ("just some words with no answer", None, None),
    ("Answer: soft", None, None),
    ("<think>only thinking</think>", None, None),
    ("<think></think><answer>soft</answer>", None, None),
    ("<think>x</think><answer>  </answer>", None, None),
    ("", None, None),
    ("", "reasoning but no final text", None),
])
def test_reply_to_output(text: str, reasoning: str | None, expected: tuple[str, str] | None) -> None:
    assert reply_to_output(TeacherReply(text=text, reasoning=reasoning)) == expected
