"""Tests for the manual audit: CSV review sheet round trip and the self-contained HTML page."""

from __future__ import annotations

import csv
import re

import numpy as np
import pytest

from tacreasoner.cot.audit import COLUMNS, export_review, import_review, stratified_sample
from tacreasoner.cot.filter import filter_samples
from tacreasoner.tasks.schema import VideoRef
from tacreasoner.video_io import write_video
from tests.cot.cot_samples import good_sample, make_item, make_sample


def _tiny_clip(path, n=12):
    """A grey pad with a round imprint that grows (press), stays (hold) and vanishes (release)."""
    frames = np.full((n, 48, 64, 3), 120, np.uint8)
    yy, xx = np.mgrid[0:48, 0:64]
    for t in range(2, n - 2):
        r = min(t, 7) * 2.5
        frames[t][(yy - 24) ** 2 + (xx - 32) ** 2 < r * r] = (170, 90, 60)
    return write_video(path, frames, fps=10)


def _samples():
    samples = [good_sample(task, seed=i) for task in ("TFA-hardness", "RFOR", "OCSE") for i in range(3)]
    bad = make_sample(make_item("TFA-hardness", item_id="wrong"), key="wrong", seed=9)
    bad.output = bad.output.replace("<answer>highly deformable", "<answer>extremely hard")
    samples.append(bad)
    filter_samples(samples)
    return samples


def _read(path):
    with open(path, encoding="utf-8", newline="") as f:
        return list(csv.DictReader(f))


def _write(path, rows):
    with open(path, "w", encoding="utf-8", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def test_csv_round_trip_with_decisions(tmp_path):
    samples = _samples()
    by_key = {s.key: s for s in samples}
    csv_path, _ = export_review(samples, tmp_path)
    rows = _read(csv_path)
    assert tuple(rows[0]) == COLUMNS
    assert [r["key"] for r in rows] == [s.key for s in samples]
    row = next(r for r in rows if r["key"] == "wrong")
    assert (row["auto_decision"], row["auto_reasons"], row["decision"]) == ("reject", "wrong_answer; contradiction", "")
    assert row["think"] and "<think>" not in row["think"]
    assert row["answer"] == "extremely hard"

    decisions = {"TFA-hardness-0": "REJECT", "TFA-hardness-1": " Accept ", "wrong": "accept", "RFOR-0": "reject"}
    for r in rows:
        r["decision"] = decisions.get(r["key"], "")
        r["comment"] = "imprint misread" if r["key"] == "TFA-hardness-0" else ""
    _write(csv_path, rows)
    result = import_review(csv_path, samples)

    assert (result.rows, result.accepted, result.rejected, result.blank) == (10, 2, 2, 6)
    assert result.overridden == 2 and result.accept_of_rejected == 1
    assert result.per_task["TFA-hardness"] == {"accept": 2, "reject": 1, "blank": 1}
    rejected = by_key["TFA-hardness-0"]
    assert rejected.review == "reject" and rejected.accepted is False
    assert rejected.reject_reasons == ["reviewer_reject"]
    assert rejected.meta["review_comment"] == "imprint misread"
    assert by_key["TFA-hardness-1"].review == "accept" and by_key["TFA-hardness-1"].accepted is True
    # A reviewer accept does not resurrect an automatic reject.
    assert by_key["wrong"].review == "accept" and by_key["wrong"].accepted is False
    assert by_key["wrong"].reject_reasons == ["wrong_answer", "contradiction"]
    assert by_key["OCSE-0"].review is None and by_key["OCSE-0"].accepted is True

    # Re-export keeps the reviews; clearing a reject withdraws it.
    csv_path, _ = export_review(samples, tmp_path)
    rows = _read(csv_path)
    assert {r["key"]: r["decision"] for r in rows}["TFA-hardness-0"] == "reject"
    for r in rows:
        if r["key"] == "TFA-hardness-0":
            r["decision"] = ""
    _write(csv_path, rows)
    import_review(csv_path, samples)
    assert rejected.review is None and rejected.accepted is True and rejected.reject_reasons == []


def test_export_does_not_overwrite_unimported_decisions(tmp_path):
    samples = _samples()
    csv_path, _ = export_review(samples, tmp_path)
    export_review(samples, tmp_path)  # nothing reviewed yet: overwriting is fine
    rows = _read(csv_path)
    rows[0]["decision"] = "reject"
    _write(csv_path, rows)
    with pytest.raises(FileExistsError, match="1 reviewer decision"):
        export_review(samples, tmp_path)
    import_review(csv_path, samples)
    export_review(samples, tmp_path)


def test_bad_decision_names_row_and_changes_nothing(tmp_path):
    samples = _samples()
    csv_path, _ = export_review(samples, tmp_path)
    rows = _read(csv_path)
    rows[0]["decision"] = "reject"
    rows[1]["decision"] = "maybe"
    _write(csv_path, rows)
    with pytest.raises(ValueError, match=r"row 3 .*'maybe'"):
        import_review(csv_path, samples)
    assert all(s.review is None for s in samples)


def test_unknown_and_repeated_keys(tmp_path):
    samples = _samples()
    csv_path, _ = export_review(samples, tmp_path)
    rows = _read(csv_path)
    _write(csv_path, [*rows, {**rows[0], "key": "nope"}])
    with pytest.raises(ValueError, match=r"row 12 .*unknown sample key 'nope'"):
        import_review(csv_path, samples)
    _write(csv_path, [*rows, rows[2]])
    with pytest.raises(ValueError, match="already reviewed in row 4"):
        import_review(csv_path, samples)
    _write(csv_path, [{"key": r["key"], "verdict": "accept"} for r in rows])
    with pytest.raises(ValueError, match="missing column"):
        import_review(csv_path, samples)


def test_html_is_self_contained_with_frames_and_placeholders(tmp_path):
    root = tmp_path / "bench"
    (root / "clips").mkdir(parents=True)
    _tiny_clip(root / "clips" / "real.mp4")
    (root / "clips" / "broken.mp4").write_bytes(b"not a video")
    item = make_item("SFD", item_id="pair", videos=[VideoRef("real", "clips/real.mp4"),
                                                     VideoRef("gone", "clips/missing.mp4")])
    sample = make_sample(item, key="pair", seed=1, think="<script>alert(1)</script> During pressing and holding "
                         "the first imprint stays small; after release both recover. So the second object is harder.")
    segment = make_sample(make_item("OCSE", item_id="seg", videos=[VideoRef("real", "clips/real.mp4", 3, 9)]),
                          key="seg", seed=2, variant="OCSE")
    broken = make_sample(make_item("RFOR", item_id="br", videos=[VideoRef("broken", "clips/broken.mp4")]),
                         key="br", seed=3, variant="RFOR")
    no_path = make_sample(make_item("RFOR", item_id="np", videos=[VideoRef("np")]), key="np", seed=4,
                          variant="RFOR")
    samples = [sample, segment, broken, no_path]
    filter_samples(samples)
    _, html_path = export_review(samples, tmp_path / "review", bench_video_root=root, frames_per_video=3)
    page = html_path.read_text(encoding="utf-8")

    assert 'src="http' not in page and "href=" not in page and "<link" not in page
    srcs = re.findall(r'src="([^"]*)"', page)
    assert srcs and all(s.startswith("data:image/png;base64,") for s in srcs)
    # Two readable videos (the pair's first, the segment): a strip and a curve each.
    assert len(srcs) == 4
    assert "clips/missing.mp4" in page and "video not readable" in page
    assert "broken.mp4" in page and "no video path recorded" in page
    assert "<script>" not in page and "&lt;script&gt;" in page
    assert '<span class="tac">[video 2]</span>' in page
    assert "[frames 3–9)" in page


def test_stratified_sample_is_deterministic_and_covers_tasks():
    samples = [good_sample(t, seed=i) for t in ("TFA-hardness", "RFOR", "OCSE") for i in range(6)]
    samples += [good_sample("OSC", seed=0)]
    picked = stratified_sample(samples, 5, seed=1)
    assert len(picked) == 5
    assert {s.task for s in picked} == {"TFA-hardness", "RFOR", "OCSE", "OSC"}
    assert [s.key for s in picked] == [s.key for s in stratified_sample(samples, 5, seed=1)]
    assert [s.key for s in picked] == [s.key for s in samples if s in picked]  # input order kept
    assert stratified_sample(samples, None) == samples


def test_export_with_n(tmp_path):
    samples = _samples()
    csv_path, html_path = export_review(samples, tmp_path, n=3)
    assert len(_read(csv_path)) == 3
    assert html_path.read_text(encoding="utf-8").count('<section class="sample"') == 3
