"""``montecarlo.seeding``: run i's stream depends only on (seed, i) (design/architecture.md §3), and chunks
partition the run ids in order."""

import math

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


def _drain(plan, a, b, workers, compile_s=2.0):
    """Hand out every chunk, worker k % workers running chunk k and reporting ``a + b n`` s of compute (its first
    chunk ``compile_s`` more)."""
    chunks = []
    while (ids := plan.next_chunk()) is not None:
        first = len(chunks) < workers
        chunks.append(ids)
        plan.finished(len(ids), a + b * len(ids) + (compile_s if first else 0.0), first_in_worker=first)
    return chunks


@pytest.mark.parametrize("a, b", [(0.0, 8.0), (1.0, 8.0), (3.5, 0.03), (0.0, 120.0), (2.0, 0.5)])
def test_chunk_plan_sizes_chunks_by_work(a, b):
    """Chunks of the runs that fill 20 s at the fitted cost a + b n, more where a would exceed a tenth of a chunk
    (a batched kind), at most MAX_CHUNK; the last chunks an even share but not below that efficiency."""
    plan = ChunkPlan(range(400), workers=2, target_s=20.0)
    chunks = _drain(plan, a, b, workers=2)
    sizes = [len(c) for c in chunks]
    assert sum(chunks, []) == list(range(400))  # every run once, in order
    assert sizes[:2] == [1, 1]  # one probe per worker
    efficient = math.ceil(9 * a / b)
    want = min(MAX_CHUNK, max(int((20 - a) / b), efficient, 1))
    assert plan.cost() == pytest.approx((a, b), rel=1e-6, abs=1e-9)
    # the steady size; one run more once, while the chunks had one size (to tell a from b)
    assert sizes.count(want) >= len(sizes) // 2 and max(sizes) <= want + 1 and sizes.count(want + 1) <= 2, sizes
    assert all(n >= min(efficient, MAX_CHUNK, want) for n in sizes[4:-1]), sizes  # the tail keeps the batching
    if a == 0:  # no fixed cost: the last chunks split what is left between the workers
        assert sizes[-1] <= max(1, want // 2 + 1)


def test_a_batched_kinds_probe_chunks_hold_an_even_share_up_to_its_probe():
    """A kind whose chunk is one vectorised pass (telemetry: probe_chunk = 50) probes with large chunks: 200 runs on
    2 workers take 4 chunks of 50 (a cost a + b n with a >> b: more, smaller chunks would repeat the pass, so the
    tail is not split below the probe's size); 20 runs are 10 + 10 (an even share: no worker idle)."""
    from sarnav.scenarios.registry import get_kind

    probe = get_kind("telemetry").probe_chunk
    assert probe == MAX_CHUNK
    sizes = [len(c) for c in _drain(ChunkPlan(range(200), workers=2, probe=probe), 1.0, 0.01, workers=2)]
    assert sizes == [50, 50, 50, 50]
    assert [len(c) for c in _drain(ChunkPlan(range(20), workers=2, probe=probe), 1.0, 0.01, workers=2)] == [10, 10]
    with pytest.raises(ValueError, match="probe"):
        ChunkPlan(range(3), probe=0)


def test_chunk_plan_a_fixed_size_is_kept():
    fixed = ChunkPlan(range(10), workers=3, size=4)
    assert [len(c) for c in _drain(fixed, 0.0, 1.0, workers=3)] == [4, 4, 2]
    with pytest.raises(ValueError, match="chunk_size"):
        ChunkPlan(range(3), size=0)
