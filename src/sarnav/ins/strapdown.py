"""Strapdown mechanization in the NED tangent frame, batched over runs.

Navigation model (thesis eq. 3.2 / 5.10), flat non-rotating Earth (``sarnav.frames``)::

    p_dot = v,   v_dot = T(q) (nu_meas - b_a) + g^n,   q_dot = 1/2 q (x) [0; omega_meas - b_g],
    b_dot = -b/tau   (every bias estimate; no process noise)

With ``earth_rate = omega_ie^t`` (an Earth-fixed tangent frame turning with the Earth, ``frames.ned``) the local
tangent-plane mechanization of Groves (2008) §5.3 adds ``-2 omega_ie^t x v`` to v_dot and ``-[omega_ie^t x] T`` to
T_dot. The attitude step becomes ``q[k+1] = q_e (x) q[k] (x) rotvec_to_quat(phi)`` with ``q_e = rotvec_to_quat(
-omega_ie^t h)`` over the interval's actual length h, exact for the constant frame rate; the Coriolis term is linear
in v and enters the same three-point (or trapezoid) rule implicitly, ``(I + 2 a [omega_ie x]) v[k+1] = rhs`` with a
the rule's weight of sample k+1 (5 h/12 on a uniform clock, h/2 for the trapezoid), solved in closed form.

The IMU gives *samples* of rate and specific force (not increments). Over one interval [t_k, t_k+1] of length
h = t_k+1 - t_k, with g = t_k - t_k-1 the previous one (samples k-1, k, k+1 of compensated rate w and nav-frame
specific force f = T f_b), the integrals use the three-point rule that is exact for quadratics: the integral over the
interval of the quadratic through the three samples. With s = t - t_k and the Lagrange basis on the nodes -g, 0, h,
``int_0^h s(s-h) ds = -h^3/6``, ``int_0^h (s+g)(s-h) ds = -h^3/6 - g h^2/2``, ``int_0^h (s+g)s ds = h^3/3 + g h^2/2``
give

    int_k^{k+1} x dt ~ a x[k+1] + b x[k] + c x[k-1],
    a = h (2h + 3g) / (6 (g + h)),   b = h (h + 3g) / (6 g),   c = -h^3 / (6 g (g + h))   (a + b + c = h),

which is ``h/12 (5, 8, -1)`` when g = h (local error O(h^4) while h/g stays bounded, O(h^3) over a flight):

* attitude: ``q[k+1] = q[k] (x) rotvec_to_quat(phi)``, ``phi = int w dt + h^2/12 w[k] x w[k+1]``
  (the second Magnus / coning term, exact for a linearly varying rate over the interval);
* velocity: ``v[k+1] = v[k] + int f dt + g^n h``; position: ``p[k+1] = p[k] + int v dt``;
* bias estimates decay as ``exp(-(t - t_0)/tau)`` at the samples' actual times.

**Sample times** need not be uniform: jittered clocks and isolated missing samples are integrated with the weights
above (``check_sample_times`` refuses unsorted, repeated or non-finite times and gaps over ``max_gap``, by default
``MAX_GAP_INTERVALS`` times the median interval: one missing sample at a time). A uniform clock (every interval within
``UNIFORM_RTOL`` of the mean, the history's too) takes the constant weights ``h/12 (5, 8, -1)`` of the mean interval,
bit-identical to the uniform-only rule this generalises. The first interval after a start or a filter reset (no
sample k-1), and an interval more than ``1/SHORT_RATIO`` times longer than the one before it (where b and c grow as
h/g and would amplify sample noise), use the trapezoid rule.
A plain trapezoid leaves an O(dt^2) attitude drift in maneuvers (1.8 mm after 60 s at 100 Hz on
the test trajectory); this rule keeps an ideal IMU at 100 Hz within 1 mm (tests/ins/test_strapdown.py), on a
jittered clock too (tests/ins/test_strapdown_jitter.py) unless a sample is missing next to a transition edge of the
maneuver, where its rate's second derivative jumps (docs/navigation.md).
On a uniform clock every sample's weights sum to dt, so integrated white noise is the random walk the filter assumes;
on any clock every interval's weights sum to its length.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sarnav.errors import InputDataError
from sarnav.frames import GRAVITY_NED, earth_rate_or_zero
from sarnav.ins.state import NavState
from sarnav.rotations import quat_multiply, rotvec_to_quat


def _matvec(T, x):
    """T @ x for stacks of 3x3 matrices; an explicit sum so results never depend on batch size."""
    return T[..., 0] * x[..., 0:1] + T[..., 1] * x[..., 1:2] + T[..., 2] * x[..., 2:3]


def _dcm(q):
    """quat_to_dcm for (R, 4) arrays, inlined for speed (same formula as sarnav.rotations)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    T = np.empty(q.shape[:1] + (3, 3))
    T[:, 0, 0] = w * w + x * x - y * y - z * z
    T[:, 0, 1] = 2 * (x * y - w * z)
    T[:, 0, 2] = 2 * (x * z + w * y)
    T[:, 1, 0] = 2 * (x * y + w * z)
    T[:, 1, 1] = w * w - x * x + y * y - z * z
    T[:, 1, 2] = 2 * (y * z - w * x)
    T[:, 2, 0] = 2 * (x * z - w * y)
    T[:, 2, 1] = 2 * (y * z + w * x)
    T[:, 2, 2] = w * w - x * x - y * y + z * z
    return T


def _cross(a, b):
    """``np.cross(a, b)`` of 3-vectors along the last axis (broadcast), written out: the same products and differences
    in numpy's order, so the same bits, without its axis handling (which took ~0.3 ms a call, a tenth of the
    navigator's time on a recording: benchmarks/bench_navigate.py)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def _rotate_body(q, phi):
    """normalize(q (x) rotvec_to_quat(phi)) for (R, 4), (R, 3) (Hamilton, scalar first)."""
    ang = np.sqrt(np.sum(phi * phi, axis=1))
    half = 0.5 * ang
    safe = np.where(ang > 1e-8, ang, 1.0)
    k = np.where(ang > 1e-8, np.sin(half) / safe, 0.5 - ang * ang / 48.0)
    r = np.cos(half)
    s = k[:, None] * phi
    a, b = q[:, :1], q[:, 1:]
    out = np.empty_like(q)
    out[:, :1] = a * r[:, None] - np.sum(b * s, axis=1, keepdims=True)
    out[:, 1:] = a * s + r[:, None] * b + _cross(b, s)
    return out / np.sqrt(np.sum(out * out, axis=1, keepdims=True))


def _solve_coriolis(rhs, w2, a):
    """x with (I + a [w2 x]) x = rhs for (R, 3) rhs: (rhs - a w2 x rhs + a^2 (w2 . rhs) w2) / (1 + a^2 |w2|^2)."""
    return (rhs - a * _cross(w2, rhs) + (a * a) * (rhs @ w2)[:, None] * w2) / (1.0 + a * a * (w2 @ w2))


MAX_GAP_INTERVALS = 2.5  # default limit on one interval, in median intervals: jitter and one missing sample pass
UNIFORM_RTOL = 1e-6  # intervals within this fraction of the mean count as a uniform clock
SHORT_RATIO = 0.25  # the three-point rule needs g >= SHORT_RATIO h (module docstring); else the trapezoid


@dataclass
class MechanizationHistory:
    """Values at the sample before the current one, for the three-point rule."""

    w_b: np.ndarray  # (R, 3) compensated angular rate
    f_n: np.ndarray  # (R, 3) nav-frame specific force
    v: np.ndarray  # (R, 3) velocity
    dt: float | None = None  # [s] from this sample to the next (the current one); None: as long as the next interval


def three_point_weights(h: float, g: float):
    """(a, b, c): ``int_{t_k}^{t_k + h} x dt ~ a x[k+1] + b x[k] + c x[k-1]`` with g = t_k - t_{k-1}, the integral of
    the quadratic through the three samples (derivation in the module docstring; h/12 (5, 8, -1) when g = h)."""
    s = g + h
    return h * (2.0 * h + 3.0 * g) / (6.0 * s), h * (h + 3.0 * g) / (6.0 * g), -(h * h * h) / (6.0 * g * s)


def _check_samples(name, a, runs, n):
    a = np.asarray(a, dtype=float)
    if a.shape != (runs, n, 3):
        raise InputDataError(name, f"must have shape (runs={runs}, samples={n}, 3), got {a.shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        r, k, _ = np.argwhere(bad)[0]
        raise InputDataError(name, f"NaN/inf IMU sample (run {r}, sample {k}); samples must be finite")
    return a


def check_sample_times(times, dt=None, field: str = "imu.time", max_gap=None) -> np.ndarray:
    """Raise InputDataError unless sample times are finite, strictly increasing and no interval exceeds ``max_gap``.

    ``dt``: the nominal interval [s] (None: the median interval); ``max_gap`` [s] (None: ``MAX_GAP_INTERVALS`` dt,
    which passes a jittered clock and isolated missing samples but not two missing in a row). Returns the times."""
    times = np.asarray(times, dtype=float)
    if times.ndim != 1 or times.size < 2:
        raise InputDataError(field, f"must be a 1-D array of at least 2 sample times [s], got shape {times.shape}")
    bad = np.flatnonzero(~np.isfinite(times))
    if bad.size:
        raise InputDataError(field, f"sample {bad[0]} is {float(times[bad[0]])}; sample times must be finite")
    gaps = np.diff(times)
    bad = np.flatnonzero(gaps <= 0)
    if bad.size:
        k = bad[0]
        raise InputDataError(field, f"sample {k + 1} at t={float(times[k + 1])!r} s does not follow "
                                    f"t={float(times[k])!r} s (unsorted or repeated time); times must increase strictly")
    nominal = float(np.median(gaps)) if dt is None else float(dt)
    if not (np.isfinite(nominal) and nominal > 0):
        raise InputDataError("dt", f"the nominal sample interval must be finite and > 0 s, got {dt!r}")
    limit = MAX_GAP_INTERVALS * nominal if max_gap is None else float(max_gap)
    if not (np.isfinite(limit) and limit > 0):
        raise InputDataError("max_gap", f"must be finite and > 0 s, got {max_gap!r}")
    bad = np.flatnonzero(gaps > limit)
    if bad.size:
        k = bad[0]
        raise InputDataError(field, f"gap of {gaps[k]:.6g} s after sample {k} (t={float(times[k])!r} s) exceeds "
                                    f"max_gap {limit:.6g} s (nominal interval {nominal:.6g} s): missing samples")
    return times


def _interval_rules(times, history):
    """Per interval: its length h [s] and the rule, three-point weights (a, b, c) or None for the trapezoid; and
    whether the clock is uniform (then h is the mean interval and the weights h/12 (5, 8, -1), the uniform rule)."""
    n = times.size
    dt = (times[-1] - times[0]) / (n - 1)
    g0 = None if history is None else history.dt
    gaps = np.diff(times)
    uniform = bool(np.all(np.abs(gaps - dt) <= UNIFORM_RTOL * dt)) and (g0 is None or abs(g0 - dt) <= UNIFORM_RTOL * dt)
    if uniform:
        rule = (5.0 * dt / 12.0, 8.0 * dt / 12.0, -(dt / 12.0))
        return [dt] * (n - 1), [None if history is None else rule] + [rule] * (n - 2), True
    hs = gaps.tolist()
    prevs = [gaps[0] if g0 is None else g0] + hs[:-1]
    rules = [None if g < SHORT_RATIO * h else three_point_weights(h, g) for h, g in zip(hs, prevs)]
    if history is None:
        rules[0] = None
    return hs, rules, False


def mechanize(nav: NavState, times, nu, omega, tau_accel: float, tau_gyro: float, tau_scalar=(), history=None,
              earth_rate=None, max_gap=None):
    """Propagate the navigation state through consecutive IMU samples.

    Parameters
    ----------
    nav : state at ``times[0]`` (the time of sample 0); not modified.
    times : (N+1,) sample times [s], strictly increasing; uniform, jittered or with isolated missing samples
        (module docstring).
    nu, omega : (R, N+1, 3) measured specific force [m/s^2] and angular rate [rad/s].
    tau_accel, tau_gyro : bias correlation times [s] (estimates decay as exp(-t/tau), eq. 3.2).
    tau_scalar : (K,) correlation times of the scalar measurement biases ``nav.bm``.
    history : the :class:`MechanizationHistory` returned by the previous call, or None after a
        start or a filter correction (then the first interval uses the trapezoid rule).
    earth_rate : omega_ie^t (3,) [rad/s] of an Earth-fixed tangent frame (``frames.earth_rate_tangent``), or None
        for the sources' non-rotating frame (module docstring).
    max_gap : the longest interval accepted [s] (``check_sample_times``; None: ``MAX_GAP_INTERVALS`` median intervals).

    Returns
    -------
    nav : state at ``times[-1]``.
    f_mean : (R, 3) mean nav-frame specific force over the interval, (delta v - g dt + int 2 omega_ie x v dt)/span.
    history : values at sample N-1 for the next call.
    """
    times = check_sample_times(times, max_gap=max_gap)
    n = times.size
    runs = nav.runs
    nu = _check_samples("imu.specific_force", nu, runs, n)
    omega = _check_samples("imu.angular_rate", omega, runs, n)

    rel = (times - times[0])[:, None]
    ba = nav.ba[:, None, :] * np.exp(-rel / tau_accel)
    bg = nav.bg[:, None, :] * np.exp(-rel / tau_gyro)
    f_b = nu - ba
    w_b = omega - bg
    hs, rules, uniform = _interval_rules(times, history)

    p, v, q = nav.p.copy(), nav.v.copy(), nav.q.copy()
    f_n = _matvec(_dcm(q), f_b[:, 0])
    v_start = v.copy()
    rotating = earth_rate is not None
    if rotating:
        w2 = 2.0 * earth_rate_or_zero(earth_rate)
        q_e = rotvec_to_quat(-0.5 * w2 * hs[0])  # every interval's on a uniform clock
        coriolis = np.zeros_like(v)  # int 2 omega_ie x v dt over the call
    prev = history
    for k in range(n - 1):
        h, rule = hs[k], rules[k]
        w0, w1 = w_b[:, k], w_b[:, k + 1]
        coning = (h * h / 12.0) * _cross(w0, w1)
        if rule is None:
            phi = 0.5 * h * (w0 + w1) + coning
        else:
            a, b, c = rule
            phi = a * w1 + b * w0 + c * prev.w_b + coning
        q_new = _rotate_body(q, phi)
        if rotating:  # the frame's turn, exact for a constant rate
            q_new = quat_multiply(q_e if uniform else rotvec_to_quat(-0.5 * w2 * h), q_new)
        f_n1 = _matvec(_dcm(q_new), f_b[:, k + 1])
        g_dt = GRAVITY_NED * h
        if rule is None:
            v_new = v + 0.5 * h * (f_n + f_n1) + g_dt
            if rotating:
                v_new = _solve_coriolis(v_new - 0.5 * h * _cross(w2, v), w2, 0.5 * h)
                coriolis += 0.5 * h * _cross(w2, v + v_new)
            p = p + 0.5 * h * (v + v_new)
        else:
            v_new = v + (a * f_n1 + b * f_n + c * prev.f_n) + g_dt
            if rotating:
                v_new = _solve_coriolis(v_new - _cross(w2, b * v + c * prev.v), w2, a)
                coriolis += _cross(w2, a * v_new + b * v + c * prev.v)
            p = p + (a * v_new + b * v + c * prev.v)
        prev = MechanizationHistory(w_b=w0, f_n=f_n, v=v, dt=h)
        q, v, f_n = q_new, v_new, f_n1
    span = times[-1] - times[0]
    f_mean = ((v - v_start + coriolis) if rotating else (v - v_start)) / span - GRAVITY_NED
    tau_scalar = np.asarray(tau_scalar, dtype=float)
    bm = nav.bm * np.exp(-span / tau_scalar) if tau_scalar.size else np.array(nav.bm, dtype=float)
    out = NavState(p=p, v=v, q=q, ba=ba[:, -1].copy(), bg=bg[:, -1].copy(), bm=bm)
    return out, f_mean, prev
