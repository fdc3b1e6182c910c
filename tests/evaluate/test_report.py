"""End-to-end report tests: two seeds of predictions for 30 hand-built items, files and numbers, comparison."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from tacreasoner.evaluate.report import (
    compare_runs,
    evaluate,
    load_predictions,
    load_scored,
    report_from_scored,
    write_comparison,
)
from tacreasoner.intervals import wilson_interval
from tacreasoner.tasks.schema import CONTACT_STATES, QAItem, VideoRef

HARD = ("highly deformable", "moderately deformable", "extremely hard")
COMBINED_FMT = "hardness: {}; protrusion: no protrusion; elasticity: moderate elasticity; friction: slight friction"


def _item(i: int, task: str, gold: dict, answer: str, n_videos: int = 1, options: tuple[str, ...] = ()) -> QAItem:
    return QAItem(id=f"q{i:02d}", task=task, question="<tactile>" * n_videos + " question?", answer=answer, gold=gold,
                  videos=[VideoRef(f"c{i}_{v}") for v in range(n_videos)], objects=[f"o{v}" for v in range(n_videos)],
                  options=list(options), source="sim")


def build_items() -> tuple[list[QAItem], dict[str, str]]:
    """30 items over every task, with one wrong (but readable) answer per item."""
    spec: list[tuple[str, dict, str, str, int, tuple[str, ...]]] = []
    for k in range(6):
        spec.append(("TFA-hardness", {"attribute": "hardness", "level": k % 3}, HARD[k % 3], HARD[(k + 1) % 3], 1, ()))
    for k in range(4):
        levels = {"hardness": k % 3, "protrusion": 0, "elasticity": 1, "friction": 0}
        spec.append(("TFA-combined", {"levels": levels}, COMBINED_FMT.format(HARD[k % 3]),
                     COMBINED_FMT.format(HARD[(k + 1) % 3]), 1, ()))
    sfd = {"attribute": "hardness", "direction": "more"}
    spec += [("SFD", {"kind": "which", "index": 0, **sfd}, "the first object", "the second object", 2, ()),
             ("SFD", {"kind": "which", "index": 1, **sfd}, "the second object", "the first object", 2, ()),
             ("SFD", {"kind": "yesno", "value": True, **sfd}, "yes", "no", 2, ()),
             ("SFD", {"kind": "yesno", "value": False, **sfd}, "no", "yes", 2, ())]
    ordinals = ("the first object", "the second object", "the third object")
    for k in range(4):
        spec.append(("SOI", {"index": k % 3, "attribute": "friction", "direction": "most"}, ordinals[k % 3],
                     ordinals[(k + 1) % 3], 3, ()))
    for assignment, text, wrong in [([0, 1, 2], "1-A, 2-B, 3-C", "1-B, 2-A, 3-C"),
                                    ([1, 0, 2], "1-B, 2-A, 3-C", "1-A, 2-B, 3-C"),
                                    ([2, 0, 1], "1-C, 2-A, 3-B", "1-A, 2-C, 3-B"),
                                    ([1, 2, 0], "1-B, 2-C, 3-A", "1-C, 2-B, 3-A")]:
        spec.append(("OSC", {"assignment": assignment}, text, wrong, 3, ("a stone", "a sponge", "a plum")))
    for letter in "ABAB":
        spec.append(("TSA", {"letter": letter, "scenario": "s", "needs": {"hardness": "high"}}, letter,
                     "B" if letter == "A" else "A", 2, ("the first object", "the second object")))
    spec += [("RFOR", {"real": True, "fruit": "apple"}, "real", "fake", 1, ()),
             ("RFOR", {"real": False, "fruit": "apple"}, "fake", "real", 1, ())]
    spec += [("OCSE", {"state": "sliding"}, "sliding", "pressing", 1, CONTACT_STATES),
             ("OCSE", {"state": "releasing"}, "releasing", "holding", 1, CONTACT_STATES)]
    items, wrong = [], {}
    for i, (task, gold, answer, bad, n_videos, options) in enumerate(spec):
        item = _item(i, task, gold, answer, n_videos, options)
        items.append(item)
        wrong[item.id] = bad
    return items, wrong


# Outcome per item, in item order per task: C right, W wrong, U unparseable, M missing.
PLAN = {
    "TFA-hardness": ("CCCCWU", "CCCWWW"),
    "TFA-combined": ("CCWW", "CCCW"),
    "SFD": ("CCCC", "CCCM"),
    "SOI": ("CCWW", "CCWW"),
    "OSC": ("CWWW", "WWWW"),
    "TSA": ("CCCW", "CCWC"),
    "RFOR": ("CW", "CC"),
    "OCSE": ("CC", "UC"),
}
# Hand-counted from PLAN (seed0 → seed1): b01 = seed0 wrong & seed1 right, b10 = seed0 right & seed1 wrong.
B01, B10 = 3, 5
SEED_ACC = {  # per task, per seed
    "TFA-hardness": (4 / 6, 3 / 6), "TFA-combined": (0.5, 0.75), "SFD": (1.0, 0.75), "SOI": (0.5, 0.5),
    "OSC": (0.25, 0.0), "TSA": (0.75, 0.75), "RFOR": (0.5, 1.0), "OCSE": (1.0, 0.5),
}


def write_predictions(items: list[QAItem], wrong: dict[str, str], tmp_path: Path) -> list[Path]:
    paths = []
    for seed in range(2):
        lines = []
        by_task: dict[str, list[QAItem]] = {}
        for item in items:
            by_task.setdefault(item.task, []).append(item)
        for task, task_items in by_task.items():
            for item, outcome in zip(task_items, PLAN[task][seed], strict=True):
                answer = {"C": item.answer, "W": wrong[item.id], "U": None, "M": None}[outcome]
                if outcome == "M":
                    continue
                text = "I am not sure." if answer is None else f"<think>cues…</think><answer>{answer}</answer>"
                lines.append({"id": item.id, "prediction": text, "latency_s": 0.1 * seed})
        if seed == 1:
            lines.append({"id": "not-an-item", "prediction": "<answer>A</answer>"})
        path = tmp_path / f"seed{seed}.jsonl"
        path.write_text("".join(json.dumps(line) + "\n" for line in lines))
        paths.append(path)
    return paths


@pytest.fixture(scope="module")
def evaluated(tmp_path_factory: pytest.TempPathFactory):
    tmp = tmp_path_factory.mktemp("eval")
    items, wrong = build_items()
    assert len(items) == 30
    paths = write_predictions(items, wrong, tmp)
    out = tmp / "out"
    return items, paths, out, evaluate(items, paths, "strict", out)


def test_files_exist(evaluated) -> None:
    _, _, out, report = evaluated
    for name in ("report.md", "report.csv", "report.json", "report.png", "scored/seed0.jsonl", "scored/seed1.jsonl"):
        assert (out / name).is_file(), name
    assert (out / "report.png").read_bytes()[:4] == b"\x89PNG"
    assert report.runs == ["seed0", "seed1"]


def test_per_task_numbers(evaluated) -> None:
    _, _, out, report = evaluated
    rows = {r.task: r for r in report.tasks}
    assert list(rows) == ["TFA-hardness", "TFA-combined", "SFD", "SOI", "OSC", "TSA", "RFOR", "OCSE"]
    for task, (a0, a1) in SEED_ACC.items():
        row = rows[task]
        assert row.per_run == pytest.approx([a0, a1]), task
        assert row.mean == pytest.approx((a0 + a1) / 2)
        assert row.std == pytest.approx(abs(a0 - a1) / 2**0.5)  # sample std of two values
        assert (row.ci_low, row.ci_high) == pytest.approx(wilson_interval((a0 + a1) / 2 * row.n, row.n))
    assert rows["TFA-hardness"].n == 6
    assert rows["TFA-hardness"].parse_failure_rate == pytest.approx(1 / 12)
    assert rows["SFD"].parse_failure_rate == pytest.approx(1 / 8)  # the missing prediction
    assert rows["OCSE"].parse_failure_rate == pytest.approx(1 / 4)
    assert rows["SOI"].parse_failure_rate == 0
    assert rows["TFA-combined"].chance == pytest.approx(1 / 81)
    assert rows["OSC"].chance == pytest.approx(1 / 6)
    assert rows["OCSE"].chance == pytest.approx(1 / 5)

    averages = [sum(a[s] for a in SEED_ACC.values()) / len(SEED_ACC) for s in (0, 1)]
    assert report.average["per_run"] == pytest.approx(averages)
    assert report.average["value"] == pytest.approx(sum(averages) / 2)
    assert report.overall["n"] == 30
    assert report.overall["per_run"] == pytest.approx([19 / 30, 17 / 30])
    assert report.missing == {"seed0": [], "seed1": ["q13"]}
    assert report.unknown_ids == {"seed0": 0, "seed1": 1}
    # "cues…" states no conclusion and names no object: nothing is checkable, and no rate is made up
    assert all(r.n_checkable == 0 and r.n_hallucinated == 0 and math.isnan(r.hallucination_rate) for r in rows.values())
    assert report.overall["n_checkable"] == 0 and math.isnan(report.overall["hallucination_rate"])

    data = json.loads((out / "report.json").read_text())
    assert data["n_runs"] == 2 and data["mode"] == "strict"
    assert data["tasks"][0]["task"] == "TFA-hardness" and data["tasks"][0]["accuracy"] == pytest.approx(7 / 12)
    assert data["average"]["value"] == pytest.approx(report.average["value"])
    assert data["tasks"][0]["hallucination_rate"] is None and data["overall"]["n_checkable"] == 0

    with (out / "report.csv").open() as f:
        csv_rows = {r["task"]: r for r in csv.DictReader(f)}
    assert float(csv_rows["OSC"]["accuracy"]) == pytest.approx(0.125)
    assert float(csv_rows["Average"]["accuracy"]) == pytest.approx(report.average["value"], abs=1e-5)
    assert csv_rows["TSA"]["per_run"] == "0.75;0.75"
    assert csv_rows["TSA"]["hallucination_rate"] == "" and csv_rows["TSA"]["n_checkable"] == "0"


def test_markdown(evaluated) -> None:
    _, _, out, report = evaluated
    md = (out / "report.md").read_text()
    assert "Mean ± std" in md
    assert "| TFA-hardness | 6 | 58.3 |" in md and "58.3 ± 11.8" in md
    assert f"**{100 * report.average['value']:.1f}**" in md
    assert "q13" in md and "no prediction" in md
    assert "| Halluc. % | Checked |" in md and "| – | 0/12 |" in md and "no checkable replies" in md
    assert "not the paper's DynTAC-Bench" in md


def test_scored_records_keep_extras(evaluated) -> None:
    _, _, out, _ = evaluated
    records = load_scored(out / "scored" / "seed1.jsonl")
    assert len(records) == 30
    first = records[0]
    assert first["extra"] == {"latency_s": 0.1} and first["mode"] == "strict" and first["source"] == "sim"
    missing = next(r for r in records if r["id"] == "q13")
    assert missing["missing"] and missing["parse_failed"] and not missing["correct"]
    assert missing["hallucinated"] is None and missing["consistency"] is None
    assert first["hallucinated"] is None and first["consistency"]["checkable"] is False


def test_report_from_scored_reproduces(evaluated, tmp_path: Path) -> None:
    _, _, out, report = evaluated
    again = report_from_scored([out / "scored" / "seed0.jsonl", out / "scored" / "seed1.jsonl"], tmp_path)
    assert [r.per_run for r in again.tasks] == [r.per_run for r in report.tasks]
    assert again.average["per_run"] == pytest.approx(report.average["per_run"])
    assert (tmp_path / "report.png").is_file()


def test_compare_runs(evaluated, tmp_path: Path) -> None:
    _, _, out, _ = evaluated
    a = load_scored(out / "scored" / "seed0.jsonl")
    b = load_scored(out / "scored" / "seed1.jsonl")
    comp = compare_runs(a, b, "seed0", "seed1")
    assert (comp.overall.b01, comp.overall.b10, comp.overall.n) == (B01, B10, 30)
    assert comp.overall.p_value == pytest.approx(2 * (1 + 8 + 28 + 56) / 2**8)  # 2·P(X ≤ 3 | n=8, ½)
    assert (comp.per_task["TSA"].b01, comp.per_task["TSA"].b10) == (1, 1)
    assert (comp.per_task["OCSE"].b01, comp.per_task["OCSE"].b10) == (0, 1)
    assert (comp.per_task["SOI"].b01, comp.per_task["SOI"].b10) == (0, 0)
    paths = write_comparison(comp, tmp_path)
    assert "| **Overall** | 30 |" in paths["md"].read_text()
    assert json.loads(paths["json"].read_text())["overall"]["b10"] == B10
    with pytest.raises(ValueError, match=r"seed0 has 30 items, seed1 has 29"):
        compare_runs(a, b[1:], "seed0", "seed1")


def test_single_run_has_no_seed_spread(evaluated, tmp_path: Path) -> None:
    items, paths, _, _ = evaluated
    report = evaluate(items, paths[:1], "lenient", tmp_path)
    md = (tmp_path / "report.md").read_text()
    assert "Mean ± std" not in md and "lenient" in md
    assert report.tasks[0].per_run == pytest.approx([4 / 6])


def test_load_predictions_errors(tmp_path: Path) -> None:
    path = tmp_path / "p.jsonl"
    path.write_text('{"id": "a", "prediction": "x", "seed": 1}\n\n{"id": "b", "prediction": "y"}\n')
    assert load_predictions(path) == {"a": {"id": "a", "prediction": "x", "seed": 1},
                                      "b": {"id": "b", "prediction": "y"}}
    for body, message in [('{"id": "a", "prediction": "x"}\n{bad json\n', "p.jsonl:2: not valid JSON"),
                          ('{"id": "a"}\n', "p.jsonl:1: missing field 'prediction'"),
                          ('{"id": 3, "prediction": "x"}\n', "p.jsonl:1: field 'id' must be a string"),
                          ('[1, 2]\n', "p.jsonl:1: expected a JSON object"),
                          ('{"id": "a", "prediction": "x"}\n{"id": "a", "prediction": "y"}\n',
                           "p.jsonl:2: duplicate id 'a' \\(first on line 1\\)")]:
        path.write_text(body)
        with pytest.raises(ValueError, match=message):
            load_predictions(path)


def test_evaluate_rejects_gold_drift(tmp_path: Path) -> None:
    items, _ = build_items()
    bad = _item(99, "RFOR", {"real": True, "fruit": "fig"}, "fake")
    path = tmp_path / "p.jsonl"
    path.write_text("")
    with pytest.raises(ValueError, match="q99"):
        evaluate([*items, bad], [path], "strict", tmp_path / "out")


# Hallucination: realistic questions and replies over three tasks; (item, reply, expected flag) per run.
def _halluc_items() -> list[QAItem]:
    rfor = [QAItem(id=f"r{k}", task="RFOR", question="<tactile>\nIs this banana real or fake?", answer=answer,
                   gold={"real": answer == "real", "fruit": "banana"}, videos=[VideoRef(f"rc{k}")], objects=[f"b{k}"],
                   source="sim") for k, answer in enumerate(["real", "fake", "real", "fake"])]
    tfa = [QAItem(id=f"t{k}", task="TFA-hardness", question="<tactile>\nWhat is the hardness level of the object?",
                  answer=HARD[k % 3], gold={"attribute": "hardness", "level": k % 3}, videos=[VideoRef(f"tc{k}")],
                  objects=[f"o{k}"], source="sim") for k in range(3)]
    sfd = [QAItem(id="s0", task="SFD", question="<tactile>\n<tactile>\nWhich object is harder?",
                  answer="the second object", gold={"kind": "which", "index": 1, "attribute": "hardness",
                                                    "direction": "more"},
                  videos=[VideoRef("sc0"), VideoRef("sc1")], objects=["x", "y"], source="sim")]
    return rfor + tfa + sfd


def _think(think: str | None, answer: str) -> str:
    return (f"<think>{think}</think>" if think else "") + f"<answer>{answer}</answer>"


HALLUC_RUNS = {
    "seed0": {
        "r0": (_think("The banana keeps a dent after release, so it is real.", "real"), False),
        "r1": (_think("It springs back at once, so this strawberry is fake.", "fake"), True),  # another object
        "r2": (_think("The banana keeps a dent, so it is real.", "fake"), True),  # concludes otherwise
        "r3": (_think(None, "fake"), None),  # no reasoning
        "t0": (_think("The imprint is broad, so the hardness is highly deformable.", HARD[0]), False),
        "t1": (_think("The imprint grows slowly during the press.", HARD[1]), None),  # no conclusion
        "t2": (_think("So the hardness is moderately deformable.", HARD[2]), True),
        "s0": (_think("Video 2 stays rigid, so the second object is harder.", "the second object"), False),
    },
    "seed1": {
        "r0": (_think("Like a ripe banana it keeps a dent, so it is real.", "real"), False),
        "r1": (_think("It springs back, so it is fake.", "fake"), False),
        "r2": (_think("So it is not fake.", "real"), False),
        "r3": (_think("It springs back, so it is fake.", "fake"), False),
        "t0": (_think("The peach-like softness shows it, so the hardness is highly deformable.", HARD[0]), False),
        "t1": (None, None),  # missing prediction
        "t2": (_think("The steel block does not dent, so the hardness is extremely hard.", HARD[2]), True),
        "s0": (_think("Video 1 yields, so the first object is softer than the second.", "the second object"), None),
    },
}


@pytest.fixture(scope="module")
def halluc(tmp_path_factory: pytest.TempPathFactory):
    tmp = tmp_path_factory.mktemp("halluc")
    paths = []
    for run, replies in HALLUC_RUNS.items():
        path = tmp / f"{run}.jsonl"
        path.write_text("".join(json.dumps({"id": i, "prediction": text}) + "\n"
                                for i, (text, _) in replies.items() if text is not None))
        paths.append(path)
    return tmp, evaluate(_halluc_items(), paths, "strict", tmp / "out")


def test_hallucination_flags_per_record(halluc) -> None:
    tmp, _ = halluc
    for run, replies in HALLUC_RUNS.items():
        records = {r["id"]: r for r in load_scored(tmp / "out" / "scored" / f"{run}.jsonl")}
        for item_id, (_, expected) in replies.items():
            assert records[item_id]["hallucinated"] is expected, (run, item_id, records[item_id]["consistency"])
    r1 = next(r for r in load_scored(tmp / "out" / "scored" / "seed0.jsonl") if r["id"] == "r1")
    assert r1["consistency"]["reasons"] == ["other_object"] and "strawberry" in r1["consistency"]["detail"]


def test_hallucination_rates_per_task_and_overall(halluc) -> None:
    tmp, report = halluc
    rows = {r.task: r for r in report.tasks}
    # RFOR: checkable 3 + 4 = 7 (r3 of seed0 has no reasoning), flagged 2; TFA-hardness: 2 + 2, flagged 1 + 1;
    # SFD: 1 + 0 (the opposite comparative is not read), flagged 0.
    assert (rows["RFOR"].n_checkable, rows["RFOR"].n_hallucinated) == (7, 2)
    assert rows["RFOR"].hallucination_rate == pytest.approx(2 / 7)
    assert rows["RFOR"].hallucination_per_run == pytest.approx([2 / 3, 0.0])
    assert (rows["TFA-hardness"].n_checkable, rows["TFA-hardness"].n_hallucinated) == (4, 2)
    assert rows["TFA-hardness"].hallucination_per_run == pytest.approx([0.5, 0.5])
    assert (rows["SFD"].n_checkable, rows["SFD"].hallucination_rate) == (1, 0.0)
    assert math.isnan(rows["SFD"].hallucination_per_run[1])
    assert report.overall["n_checkable"] == 12 and report.overall["n_hallucinated"] == 4
    assert report.overall["hallucination_rate"] == pytest.approx(4 / 12)

    md = (tmp / "out" / "report.md").read_text()
    assert "| TFA-hardness | 3 | 83.3 |" in md and "| 50.0 | 4/6 |" in md and "| 28.6 | 7/8 |" in md
    assert "overall hallucination = 33.3% of 12 checkable replies" in md
    with (tmp / "out" / "report.csv").open() as f:
        csv_rows = {r["task"]: r for r in csv.DictReader(f)}
    assert float(csv_rows["RFOR"]["hallucination_rate"]) == pytest.approx(2 / 7)
    assert (csv_rows["RFOR"]["n_checkable"], csv_rows["RFOR"]["n_hallucinated"]) == ("7", "2")
    data = json.loads((tmp / "out" / "report.json").read_text())
    by_task = {t["task"]: t for t in data["tasks"]}
    assert by_task["SFD"]["hallucination_per_run"] == [0.0, None]
    assert data["overall"]["hallucination_rate"] == pytest.approx(1 / 3)


def test_report_from_scored_keeps_and_tolerates_missing_flags(halluc, tmp_path: Path) -> None:
    tmp, report = halluc
    scored = [tmp / "out" / "scored" / f"{run}.jsonl" for run in HALLUC_RUNS]
    again = report_from_scored(scored, tmp_path / "again")
    assert [(r.n_checkable, r.n_hallucinated) for r in again.tasks] == [(r.n_checkable, r.n_hallucinated)
                                                                       for r in report.tasks]
    # Records written before the check existed have no "hallucinated" key: not checkable, never counted.
    old = []
    for path in scored:
        records = [{k: v for k, v in r.items() if k not in ("hallucinated", "consistency")} for r in load_scored(path)]
        out = tmp_path / path.name
        out.write_text("".join(json.dumps(r) + "\n" for r in records))
        old.append(out)
    legacy = report_from_scored(old, tmp_path / "legacy")
    assert [r.per_run for r in legacy.tasks] == [r.per_run for r in report.tasks]
    assert all(r.n_checkable == 0 and math.isnan(r.hallucination_rate) for r in legacy.tasks)
    assert "no checkable replies" in (tmp_path / "legacy" / "report.md").read_text()
