"""``montecarlo.seeding``: run i's stream depends only on (seed, i) (design/architecture.md §3), and chunks
partition the run ids in order."""

import numpy as np
import pytest

from sarnav.montecarlo.seeding import MAX_CHUNK, ChunkPlan, make_chunks, run_seeds


def test_run_i_gets_child_i_whatever_the_number_of_runs():
    few, many = run_seeds(2022, 3), run_seeds(2022, 40)
    for i, s in enumerate(few):
        assert s.spawn_key == (i,) and s.entropy == 2022
        np.testing.assert_array_equal(np.random.default_rng(s).random(5), np.random.default_rng(many[i]).random(5))
    streams = [np.random.default_rng(s).random(2000) for s in many[:4]]
    assert np.abs(np.corrcoef(streams)[np.triu_indices(4, 1)]).max() < 0.1  # distinct streams


@pytest.mark.parametrize("n, size", [(10, 3), (7, 7), (5, 50)])
def test_chunks_partition_the_runs_in_order(n, size):
    ids = list(range(100, 100 + n))
    chunks = make_chunks(ids, size)
    assert sum(chunks, []) == ids
    assert all(len(c) == size for c in chunks[:-1]) and 1 <= len(chunks[-1]) <= size
    with pytest.raises(ValueError, match="chunk_size"):
        make_chunks(ids, 0)


def _drain(plan, seconds_per_run, fixed=0.0):
    """Hand out every chunk, reporting each as taking ``fixed + n * seconds_per_run`` s of compute."""
    chunks = []
    while (ids := plan.next_chunk()) is not None:
        chunks.append(ids)
        plan.finished(len(ids), fixed + len(ids) * seconds_per_run)
    return chunks


@pytest.mark.parametrize("per_run, fixed", [(8.0, 0.0), (8.0, 3.0), (0.01, 0.5), (120.0, 0.0)])
def test_chunk_plan_sizes_chunks_by_work(per_run, fixed):
    plan = ChunkPlan(range(200), workers=2, target_s=20.0)
    chunks = _drain(plan, per_run, fixed)
    assert sum(chunks, []) == list(range(200))  # every run once, in order
    assert [len(c) for c in chunks[:2]] == [1, 1]  # one probe per worker
    # after the probes: the largest chunk of at most 20 s at the cost measured, capped, growing at most 4x a step
    sizes = [len(c) for c in chunks]
    for prev, n in zip(sizes[1:], sizes[2:]):
        assert n <= 4 * max(sizes[: sizes.index(prev) + 1])
    middle = sizes[2:-4]
    want = max(1, min(MAX_CHUNK, int(20.0 / (per_run + fixed / max(middle or [1])))))
    steady = [n for n in middle if n == max(middle)] if middle else []
    assert steady and abs(max(middle) - want) <= max(1, want // 4), (sizes, want)
    assert all((fixed + n * per_run) <= 20.0 or n == 1 for n in middle)


def test_chunk_plan_ends_with_an_even_share_and_a_fixed_size_is_kept():
    plan = ChunkPlan(range(40), workers=4)
    sizes = [len(c) for c in _drain(plan, 0.001)]
    assert sum(sizes) == 40 and sizes[:4] == [1, 1, 1, 1]
    assert max(sizes) <= -(-36 // 4)  # never more than an even share of what was left per worker
    fixed = ChunkPlan(range(10), workers=3, size=4)
    assert [len(c) for c in _drain(fixed, 1.0)] == [4, 4, 2]
    with pytest.raises(ValueError, match="chunk_size"):
        ChunkPlan(range(3), size=0)
