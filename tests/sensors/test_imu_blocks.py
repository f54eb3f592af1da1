import numpy as np

from sarnav.sensors.imu import ImuBlocks, ImuModel, imu_grade


def _feed(seed):
    imu = ImuModel(imu_grade("tactical"), 100.0, 3600.0, 3600.0)
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(2)]
    ba, bg = imu.initial_biases(rngs)
    t = np.arange(31) / 100.0
    nu = np.tile([0.0, 0.0, -9.81], (t.size, 1))
    om = np.zeros((t.size, 3))
    return ImuBlocks(imu, nu, om, ba, bg, rngs)


def test_blocks_share_their_boundary_sample_and_are_seeded():
    a, b = _feed(7), _feed(7)
    first = a.first
    blocks = [a.next(10) for _ in range(3)]
    assert all(x.shape == (2, 11, 3) for blk in blocks for x in blk)
    for k in range(4):  # nu, omega, ba path, bg path
        np.testing.assert_array_equal(blocks[0][k][:, :1], first[k])
        for prev, cur in zip(blocks, blocks[1:]):
            np.testing.assert_array_equal(cur[k][:, :1], prev[k][:, -1:])
    again = [b.next(10) for _ in range(3)]
    for x, y in zip(blocks, again):
        for u, v in zip(x, y):
            np.testing.assert_array_equal(u, v)
    # the specific force carries the accelerometer bias path plus white noise of the VRW density
    noise = blocks[0][0][:, 1:] - np.array([0.0, 0.0, -9.81]) - blocks[0][2][:, 1:]
    assert 0.7 < np.std(noise) / (imu_grade("tactical").vrw * np.sqrt(100.0)) < 1.3  # 60 samples: 9% standard error
