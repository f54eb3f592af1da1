"""``montecarlo.seeding``: run i's stream depends only on (seed, i) (design/architecture.md §3), and chunks
partition the run ids in order."""

import numpy as np
import pytest

from sarnav.montecarlo.seeding import default_chunk_size, make_chunks, run_seeds


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


def test_default_chunk_size_is_about_two_per_worker_at_most_50():
    assert default_chunk_size(200, 2) == 50 and default_chunk_size(40, 4) == 5 and default_chunk_size(3, 8) == 1
    assert default_chunk_size(1000, 1) == 50 and default_chunk_size(0, 4) == 1
