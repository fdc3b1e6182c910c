"""TouchCoT step 1: jobs from a benchmark split — stages, pixel cues, segments and the per-clip cue cache."""

from __future__ import annotations

import math
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from tacreasoner.cot import prepare
from tacreasoner.cot.prepare import CueCache, PrepareStats, clip_cue_table, prepare_jobs, stages_for
from tacreasoner.cot.schema import STAGES, CoTJob
from tacreasoner.data.cache import load_frames
from tacreasoner.data.cues import frame_signals
from tacreasoner.data.readers import read_sim_dataset
from tacreasoner.data.sampling import background_frame
from tacreasoner.tasks.bench import load_bench
from tests.cot.touchcot_bench import prepared

ACTIONS = {"slide", "rotate"}


@pytest.fixture(scope="module")
def setup(small_sim_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[CoTJob], PrepareStats]:
    return prepared(small_sim_dataset, tmp_path_factory.mktemp("touchcot"))


@pytest.fixture(scope="module")
def jobs(setup) -> list[CoTJob]:
    return setup[1]


@pytest.fixture(scope="module")
def sim_clips(small_sim_dataset: Path) -> dict:
    return {c.clip_id: c for c in read_sim_dataset(small_sim_dataset)}


def _present(job: CoTJob) -> set[str]:
    return {s for v in job.videos for s in v.phases}


def test_jobs_cover_the_split_but_never_tsa(setup, tmp_path: Path) -> None:
    bench, jobs, _ = setup
    _, items = load_bench(bench, "train")
    assert [j.item.id for j in jobs] == [i.id for i in items]
    assert {"TFA-hardness", "SFD", "SOI", "OSC", "RFOR", "OCSE", "TFA-combined"} <= {j.item.task for j in jobs}
    val_stats = PrepareStats()
    val_jobs = prepare_jobs(bench, "val", cache_dir=tmp_path / "cues", stats=val_stats)
    val_items = load_bench(bench, "val")[1]
    assert any(i.task == "TSA" for i in val_items), "the fixture should have TSA items to leave out"
    assert not any(j.item.task == "TSA" for j in val_jobs)
    assert val_stats.skipped_zero_shot == sum(i.task == "TSA" for i in val_items)
    assert len(val_jobs) == len(val_items) - val_stats.skipped_zero_shot
    with pytest.raises(ValueError, match="zero-shot"):
        prepare_jobs(bench, "val", cache_dir=tmp_path / "cues", tasks=["TSA"])
    with pytest.raises(ValueError, match="unknown task"):
        prepare_jobs(bench, "val", cache_dir=tmp_path / "cues", tasks=["TFA-smell"])


def test_tasks_and_limit_select_jobs(setup, tmp_path: Path) -> None:
    bench = setup[0]
    only = prepare_jobs(bench, "train", cache_dir=tmp_path / "cues", tasks=["RFOR", "OCSE"], limit=5)
    assert len(only) == 5 and {j.item.task for j in only} <= {"RFOR", "OCSE"}


def test_stages_follow_the_task_and_the_clip(jobs: list[CoTJob]) -> None:
    for job in jobs:
        task, present = job.item.task, _present(job)
        assert job.stages == [s for s in STAGES if s in job.stages], f"{job.item.id}: not in temporal order"
        if task == "OCSE":
            state_stage = prepare.STATE_TO_PHASE[job.item.gold["state"]]
            assert job.stages == [state_stage]
            assert set(job.videos[0].phases) == {state_stage}, "a segment holds only its own stage"
            continue
        assert set(job.stages) <= present, f"{job.item.id}: requires a stage no video shows"
        attribute = task.removeprefix("TFA-") if task.startswith("TFA-") else job.item.gold.get("attribute")
        if task in ("TFA-hardness", "TFA-elasticity") or (task in ("SFD", "SOI") and attribute in
                                                           ("hardness", "elasticity")):
            expected = {"press", "hold", "release"} | (ACTIONS & present)
        elif task == "TFA-friction" or attribute == "friction":
            expected = {"press", "release"} | (ACTIONS & present)
        elif attribute in ("protrusion", "roughness", "bumpiness"):
            expected = {"press", "hold"} | (ACTIONS & present)
        elif task in ("TFA-combined", "OSC"):
            expected = present
        elif task == "RFOR":
            expected = {"press", "hold", "release"}
        else:
            raise AssertionError(f"unexpected task {task}")
        assert set(job.stages) == expected & present, f"{job.item.id} ({task}, {attribute})"


def test_stages_without_cues_use_the_known_action(jobs: list[CoTJob]) -> None:
    item = next(j.item for j in jobs if j.item.task == "TFA-friction")
    assert stages_for(item) == ["press", "slide", "rotate", "release"]
    item.meta["action"] = "rotate"
    try:
        assert stages_for(item) == ["press", "rotate", "release"]
    finally:
        item.meta.pop("action")


def test_cues_are_finite_numbers_with_stage_timings(jobs: list[CoTJob], sim_clips: dict) -> None:
    for job in jobs:
        for ref, video in zip(job.item.videos, job.videos, strict=True):
            assert video.clip_id == ref.clip_id
            assert video.phase_source == "ground_truth"
            assert video.fps == pytest.approx(sim_clips[ref.clip_id].fps)
            assert video.cues and all(isinstance(v, float) and math.isfinite(v) for v in video.cues.values())
            for stage, (s, e) in video.phases.items():
                assert stage in STAGES and 0 <= s < e
                assert video.cues[f"{stage}_start_s"] == pytest.approx(s / video.fps)
                assert video.cues[f"{stage}_end_s"] == pytest.approx(e / video.fps)
            if "press" in video.phases:
                s, e = video.phases["press"]
                assert 0.0 <= video.cues["time_to_max_contact_s"] <= (e - s) / video.fps
                assert 0.0 < video.cues["press_area"] <= video.cues["max_area"] <= 1.0


def test_phases_are_the_simulator_ground_truth(jobs: list[CoTJob], sim_clips: dict) -> None:
    job = next(j for j in jobs if j.item.task == "TFA-hardness")
    truth = np.asarray(sim_clips[job.videos[0].clip_id].phases, dtype=object)
    for stage, (s, e) in job.videos[0].phases.items():
        idx = np.flatnonzero(truth == stage)
        assert (s, e) == (idx[0], idx[-1] + 1)


def test_ocse_cues_are_measured_on_the_segment_only(jobs: list[CoTJob], sim_clips: dict) -> None:
    job = next(j for j in jobs if j.item.task == "OCSE")
    ref, video = job.item.videos[0], job.videos[0]
    clip = sim_clips[ref.clip_id]
    frames = load_frames(clip.path)
    signals = frame_signals(frames, background_frame(frames, clip.phases))
    n = ref.end - ref.start
    assert video.cues["duration_s"] == pytest.approx(n / clip.fps)
    assert video.cues["max_area"] == pytest.approx(float(signals.area[ref.start:ref.end].max()), rel=1e-5)
    assert video.cues["contact_fraction"] == pytest.approx(1.0)  # a contact segment: every frame in contact
    assert {"seg_area_start", "seg_area_end", "seg_area_change", "seg_motion"} <= set(video.cues)
    (stage, (s, e)), = video.phases.items()
    assert (s, e) == (0, n) and stage == clip.phases[ref.start]
    whole = clip_cue_table(clip.path, clip.phases, clip.fps, clip.action, clip_id=clip.clip_id)
    assert whole.cues["duration_s"] > video.cues["duration_s"]
    assert "seg_area_start" not in whole.cues


def test_cue_tables_are_computed_once_per_clip_and_then_cached(setup, tmp_path: Path, monkeypatch) -> None:
    bench, jobs, _ = setup
    calls: list[str] = []
    original = prepare._cue_tables

    def counting(path, phases, fps, action, segments, clip_id):
        calls.append(clip_id)
        return original(path, phases, fps, action, segments, clip_id)

    monkeypatch.setattr(prepare, "_cue_tables", counting)
    first = PrepareStats()
    fresh = prepare_jobs(bench, "train", cache_dir=tmp_path / "cues", stats=first)
    n_refs = sum(len(j.item.videos) for j in fresh)
    assert len(calls) == len(set(calls)) == first.clips, "one measurement per clip"
    assert first.clips < n_refs, "clips are shared between items"
    assert first.computed == first.tables and first.cached == 0
    assert len(list((tmp_path / "cues").glob("*.json"))) == first.clips

    calls.clear()
    second = PrepareStats()
    again = prepare_jobs(bench, "train", cache_dir=tmp_path / "cues", stats=second)
    assert calls == [] and second.computed == 0 and second.cached == second.tables == first.tables
    assert [j.videos for j in again] == [j.videos for j in fresh] == [j.videos for j in jobs]


def test_cache_entries_follow_the_video_file(sim_clips: dict, tmp_path: Path) -> None:
    clip = next(iter(sim_clips.values()))
    video = tmp_path / "clip.mp4"
    shutil.copy(clip.path, video)
    table = clip_cue_table(video, clip.phases, clip.fps, clip.action, clip_id=clip.clip_id)
    cache = CueCache(tmp_path / "cache")
    cache.store(clip.clip_id, video, {"whole": table})
    assert cache.lookup(clip.clip_id, video) == {"whole": table}
    assert cache.lookup("another/clip", video) == {}
    st = video.stat()
    os.utime(video, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    assert cache.lookup(clip.clip_id, video) == {}, "a changed video must be measured again"
    cache.file_for(clip.clip_id).write_text("{ not json")
    assert cache.lookup(clip.clip_id, video) == {}


def test_real_video_phases_are_detected(sim_clips: dict) -> None:
    clip = next(c for c in sim_clips.values() if c.action == "rotate")
    table = clip_cue_table(clip.path, None, clip.fps, "rotate", clip_id=clip.clip_id)
    assert table.phase_source == "detected"
    assert "press" in table.phases and "rotate" in table.phases and "slide" not in table.phases
    with pytest.raises(ValueError, match="phase labels"):
        clip_cue_table(clip.path, clip.phases[:-3], clip.fps, clip.action, clip_id=clip.clip_id)
    with pytest.raises(ValueError, match="segment"):
        clip_cue_table(clip.path, clip.phases, clip.fps, clip.action, start=5, end=5)


def test_workers_give_the_same_tables_and_report_progress(setup, tmp_path: Path) -> None:
    bench, jobs, _ = setup
    seen: list[tuple[int, int]] = []
    parallel = prepare_jobs(bench, "train", cache_dir=tmp_path / "cues", workers=2,
                            progress=lambda done, total: seen.append((done, total)))
    assert seen[0][0] == 0 and seen[-1][0] == seen[-1][1] == len({r.clip_id for j in jobs for r in j.item.videos})
    for a, b in zip(parallel, jobs, strict=True):
        for va, vb in zip(a.videos, b.videos, strict=True):
            assert va.phases == vb.phases
            assert va.cues == pytest.approx(vb.cues)
