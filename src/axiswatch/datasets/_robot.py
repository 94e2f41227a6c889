"""A physically motivated simulator of one robot axis running pick-and-place tasks.

The paper's robot data is confidential, so its figs. 3-4 are reproduced on this simulator.
docs/internals.md, "The simulated axis", gives the model, the sensors and the faults.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from axiswatch._capture import Capture

__all__ = [
    "NOMINAL_AXIS",
    "TASKS",
    "AxisSpec",
    "Fault",
    "Task",
    "simulate_capture",
]

FaultKind = Literal["backlash", "friction", "tooth", "bearing"]
FAULT_KINDS: tuple[str, ...] = ("backlash", "friction", "tooth", "bearing")

POSITION_RATE_HZ = 250.0
FAST_RATE_HZ = 2000.0
_WARMUP_S = 0.25

GEAR_RATIO = 100.0
MESH_ORDER = 2.0  # ripple cycles per motor revolution (e.g. the two lobes of a strain-wave gear)
TOOTH_STAGE_RATIO = 5.0  # motor revolutions per revolution of the gear with the damaged tooth
TOOTH_COUNT = 24
BEARING_ORDER = 5.43  # inner-race defect frequency, in orders of the motor speed

# Nominal axis (link side units: kg m^2, N m, N m s/rad, rad).
_J_MOTOR = 5.0
_J_LINK = 4.0
_ARM_M = 1.0  # payload lever L
_LINK_MOMENT = 8.0 * 0.4  # m_l l_c, kg m
_GRAVITY = 9.81
_STIFFNESS = 6.0e4
_DAMPING = 150.0
_BACKLASH = 3e-4
_COULOMB = 12.0
_VISCOUS = 4.0
_STRIBECK_SPEED = 0.02
_RIPPLE = 1.5
_KP = 2.5e4
_KD = 7.0e2

# Fault amplitudes at severity 1.
_BACKLASH_GROWTH = 6e-3
_COULOMB_GROWTH = 3.0
_VISCOUS_GROWTH = 2.0
_TOOTH_IMPACT = 40.0
_BEARING_IMPACT = 15.0

# Sensor noise (standard deviations).
_NOISE_POSITION = 2e-5
_NOISE_SPEED = 2e-3
_NOISE_TORQUE = 0.3


@dataclass(frozen=True)
class Task:
    """A pick-and-place task of one axis.

    One cycle: move from the pick to the place position (carrying the payload), dwell at the
    place, move back empty, dwell at the pick. Moves follow a minimum-jerk profile.

    Parameters
    ----------
    name : str
    amplitude_rad : float
        Distance between pick and place positions (link side).
    move_s : float
        Duration of one move (sets the speed: peak speed is 1.875 amplitude / move).
    dwell_place_s, dwell_pick_s : float
        Dwell times at the place and pick positions.
    payload_kg : float
        Mass carried from pick to place, at the arm length of 1 m.
    offset_rad : float
        Pick position (0 = link horizontal, where gravity acts most).
    cruise_fraction : float in [0, 1), default=0.0
        0: minimum-jerk moves; above 0: trapezoidal moves that cruise at constant speed for this
        share of the move (constant-speed moves, as in conveyor tracking or gluing).

    Examples
    --------
    >>> TASKS["short_fast"].cycle_s
    1.0
    """

    name: str
    amplitude_rad: float
    move_s: float
    dwell_place_s: float
    dwell_pick_s: float
    payload_kg: float
    offset_rad: float
    cruise_fraction: float = 0.0

    @property
    def cycle_s(self) -> float:
        """Duration of one task cycle."""
        return 2.0 * self.move_s + self.dwell_place_s + self.dwell_pick_s


#: Eight pick-and-place tasks: amplitudes 0.4-1.5 rad, moves 0.3-1.0 s, dwells 0.1-0.6 s,
#: payloads 0.5-10 kg, cycles 1.0-2.6 s.
TASKS: dict[str, Task] = {
    task.name: task
    for task in (
        Task("short_fast", 0.6, 0.35, 0.15, 0.15, 2.0, 0.3),
        Task("short_slow", 0.6, 0.7, 0.2, 0.2, 2.0, 0.3),
        Task("long_fast", 1.5, 0.6, 0.2, 0.2, 5.0, 0.0),
        Task("long_slow", 1.5, 1.0, 0.3, 0.3, 5.0, 0.0),
        Task("heavy", 1.0, 0.7, 0.3, 0.3, 10.0, 0.5),
        Task("light", 1.0, 0.45, 0.1, 0.1, 0.5, -0.3),
        Task("palletize", 1.2, 0.55, 0.5, 0.1, 8.0, 0.8),
        Task("inspect", 0.4, 0.3, 0.6, 0.6, 1.0, 1.2),
    )
}


@dataclass(frozen=True)
class Fault:
    """A mechanical fault of the axis and how far it has developed.

    Parameters
    ----------
    kind : {"backlash", "friction", "tooth", "bearing"}
    severity : float in [0, 1]
        0 is healthy, 1 is the most developed (just before breakdown).

    Examples
    --------
    >>> Fault("tooth", 0.5)
    Fault(kind='tooth', severity=0.5)
    """

    kind: FaultKind
    severity: float

    def __post_init__(self) -> None:
        if self.kind not in FAULT_KINDS:
            raise ValueError(
                f"The 'kind' parameter of Fault must be one of {list(FAULT_KINDS)}. "
                f"Got {self.kind!r} instead."
            )
        if not (
            isinstance(self.severity, int | float | np.floating) and 0.0 <= self.severity <= 1.0
        ):
            raise ValueError(
                f"The 'severity' parameter of Fault must be a float in [0, 1]. "
                f"Got {self.severity!r} instead."
            )


@dataclass(frozen=True)
class _Reference:
    """Reference trajectory sampled on the integration grid."""

    position: NDArray[np.float64]
    speed: NDArray[np.float64]
    acceleration: NDArray[np.float64]
    carrying: NDArray[np.bool_]


def _profile(
    tau: NDArray[np.float64], move_s: float, cruise_fraction: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Normalised path ``s(tau)`` in [0, 1] and its time derivatives, ``tau`` in [0, 1]."""
    T = move_s
    if cruise_fraction <= 0.0:
        s = tau**3 * (10 - 15 * tau + 6 * tau**2)
        ds = 30 * tau**2 * (1 - tau) ** 2 / T
        dds = 60 * tau * (1 - tau) * (1 - 2 * tau) / T**2
        return s, ds, dds
    # Trapezoid: accelerate over a share r of the move, cruise, decelerate over r.
    r = (1.0 - cruise_fraction) / 2.0
    peak = 1.0 / (T * (1.0 - r))
    accel = peak / (r * T)
    t = tau * T
    rise, fall = t < r * T, t > (1.0 - r) * T
    s = np.where(
        rise,
        0.5 * accel * t**2,
        np.where(fall, 1.0 - 0.5 * accel * (T - t) ** 2, peak * (t - 0.5 * r * T)),
    )
    ds = np.where(rise, accel * t, np.where(fall, accel * (T - t), peak))
    dds = np.where(rise, accel, np.where(fall, -accel, 0.0))
    return s, ds, dds


def _reference(task: Task, time_s: NDArray[np.float64]) -> _Reference:
    """Pick-and-place reference at times ``time_s`` (0 = start of a forward move)."""
    t = np.mod(time_s, task.cycle_s)
    T, A = task.move_s, task.amplitude_rad
    back_start = T + task.dwell_place_s
    forward = t < T
    back = (t >= back_start) & (t < back_start + T)
    tau = np.where(forward, t / T, np.where(back, (t - back_start) / T, 0.0))
    s, ds, dds = _profile(tau, T, task.cruise_fraction)
    at_place = (t >= T) & (t < back_start)
    position = task.offset_rad + A * np.where(
        forward, s, np.where(back, 1 - s, np.where(at_place, 1.0, 0.0))
    )
    speed = A * np.where(forward, ds, np.where(back, -ds, 0.0))
    acceleration = A * np.where(forward, dds, np.where(back, -dds, 0.0))
    return _Reference(position, speed, acceleration, forward | at_place)


@dataclass(frozen=True)
class AxisSpec:
    """Every physical and logging parameter of one simulated axis (link-side units).

    The defaults are the project's original axis (``GEAR_RATIO``, ``_COULOMB``, ...), so that
    :func:`simulate_capture` without a ``spec`` is unchanged; a robot family
    (:func:`~axiswatch.draw_axis`) draws each field.

    Parameters
    ----------
    gear_ratio, mesh_order, tooth_stage_ratio, tooth_count, bearing_order : float
        Kinematics: motor turns per link turn, ripple cycles per motor turn, motor turns per turn
        of the gear that may lose a tooth, its teeth, the bearing's inner-race defect order.
    j_motor, j_link, arm_m, link_moment : float
        Inertias (kg m^2), payload lever (m) and the link's gravity moment ``m_l l_c`` (kg m;
        near 0 for a wrist or horizontal axis).
    stiffness, damping, backlash : float
        Gearbox (N m/rad, N m s/rad, rad half-gap).
    coulomb, viscous, stribeck_speed, stribeck_peak : float
        Friction ``(F_c + F_s exp(-(w/w_s)^2)) tanh(w/w_s) + F_v w``.
    temperature_coefficient : float
        Relative change of friction per kelvin away from 30 degC (oil viscosity).
    ripple, kp, kd : float
        Gear-mesh ripple amplitude (N m) and controller gains.
    position_rate_hz, fast_rate_hz : float
        Logging rates of the position and of speed and torque; each divides 4 kHz.
    position_quantum, torque_quantum : float
        Resolution of the logged position (rad) and torque (N m); 0 = not quantised.
    noise_position, noise_speed, noise_torque : float
        Sensor noise standard deviations.
    tooth_impact, bearing_impact : float
        Fault impacts (N m) at severity 1.
    coulomb_growth, viscous_growth : float
        Relative growth of the friction terms at severity 1.
    backlash_growth : float
        Growth of the backlash half-gap (rad) at severity 1.
    """

    gear_ratio: float = GEAR_RATIO
    mesh_order: float = MESH_ORDER
    tooth_stage_ratio: float = TOOTH_STAGE_RATIO
    tooth_count: int = TOOTH_COUNT
    bearing_order: float = BEARING_ORDER
    j_motor: float = _J_MOTOR
    j_link: float = _J_LINK
    arm_m: float = _ARM_M
    link_moment: float = _LINK_MOMENT
    stiffness: float = _STIFFNESS
    damping: float = _DAMPING
    backlash: float = _BACKLASH
    coulomb: float = _COULOMB
    viscous: float = _VISCOUS
    stribeck_speed: float = _STRIBECK_SPEED
    stribeck_peak: float = 0.0
    temperature_coefficient: float = 0.0
    ripple: float = _RIPPLE
    kp: float = _KP
    kd: float = _KD
    position_rate_hz: float = POSITION_RATE_HZ
    fast_rate_hz: float = FAST_RATE_HZ
    position_quantum: float = 0.0
    torque_quantum: float = 0.0
    noise_position: float = _NOISE_POSITION
    noise_speed: float = _NOISE_SPEED
    noise_torque: float = _NOISE_TORQUE
    tooth_impact: float = _TOOTH_IMPACT
    bearing_impact: float = _BEARING_IMPACT
    coulomb_growth: float = _COULOMB_GROWTH
    viscous_growth: float = _VISCOUS_GROWTH
    backlash_growth: float = _BACKLASH_GROWTH


#: The project's original axis.
NOMINAL_AXIS = AxisSpec()

#: Integration rate of :func:`_simulate_axis`: every logging rate divides it.
INTEGRATION_RATE_HZ = 4000.0


@dataclass(frozen=True)
class _Trajectory:
    """Noise-free states on the integration grid (for tests and diagnostics)."""

    time_s: NDArray[np.float64]
    motor_position: NDArray[np.float64]
    motor_speed: NDArray[np.float64]
    link_position: NDArray[np.float64]
    motor_torque: NDArray[np.float64]
    transmission_torque: NDArray[np.float64]
    reference_position: NDArray[np.float64]


def _simulate_axis(
    task: Task,
    fault: Fault | None,
    duration_s: float,
    phase_s: float,
    spec: AxisSpec = NOMINAL_AXIS,
    temperature_c: float = 30.0,
) -> _Trajectory:
    """Integrate the axis over ``duration_s`` seconds of the task, starting ``phase_s`` into a cycle."""
    dt = 1.0 / INTEGRATION_RATE_HZ
    n_warm = round(_WARMUP_S / dt)
    n_steps = n_warm + round(duration_s / dt)
    time_s = phase_s - _WARMUP_S + np.arange(n_steps, dtype=np.float64) * dt
    ref = _reference(task, time_s)
    payload = np.where(ref.carrying, task.payload_kg, 0.0)
    link_inertia = spec.j_link + payload * spec.arm_m**2
    gravity_moment = _GRAVITY * (spec.link_moment + payload * spec.arm_m)
    # The controller's model is the nominal one: it knows neither temperature nor Stribeck peak.
    feed_forward = (
        (spec.j_motor + link_inertia) * ref.acceleration
        + spec.viscous * ref.speed
        + spec.coulomb * np.tanh(ref.speed / spec.stribeck_speed)
        + gravity_moment * np.cos(ref.position)
    )
    kind = fault.kind if fault is not None else None
    severity = fault.severity if fault is not None else 0.0
    warm = 1.0 + spec.temperature_coefficient * (temperature_c - 30.0)
    backlash = spec.backlash + (spec.backlash_growth * severity if kind == "backlash" else 0.0)
    coulomb = spec.coulomb * (1 + (spec.coulomb_growth * severity if kind == "friction" else 0.0))
    viscous = spec.viscous * (1 + (spec.viscous_growth * severity if kind == "friction" else 0.0))
    if spec.temperature_coefficient:
        coulomb, viscous = coulomb * warm, viscous * warm
    stribeck = spec.stribeck_peak
    tooth = spec.tooth_impact * severity if kind == "tooth" else 0.0
    bearing = spec.bearing_impact * severity if kind == "bearing" else 0.0
    half_tooth = math.pi / spec.tooth_count
    damaged_at = 1.0  # angle of the damaged tooth on its gear, rad
    stiffness, damping, j_motor = spec.stiffness, spec.damping, spec.j_motor
    kp, kd, ripple, mesh = spec.kp, spec.kd, spec.ripple, spec.mesh_order
    gear_ratio, stage_ratio, bearing_order = (
        spec.gear_ratio,
        spec.tooth_stage_ratio,
        spec.bearing_order,
    )
    stribeck_speed = spec.stribeck_speed

    # Start on the reference, gearbox preloaded by the static load.
    q_m = float(ref.position[0])
    static = float(gravity_moment[0] * np.cos(ref.position[0]))
    q_l = q_m - static / stiffness - math.copysign(backlash, static)
    w_m = w_l = float(ref.speed[0])
    out_qm = np.empty(n_steps)
    out_wm = np.empty(n_steps)
    out_ql = np.empty(n_steps)
    out_tau = np.empty(n_steps)
    out_ts = np.empty(n_steps)
    # Plain floats in the loop: NumPy scalars would be several times slower.
    q_ref, w_ref, ff = ref.position.tolist(), ref.speed.tolist(), feed_forward.tolist()
    j_link, g_moment = link_inertia.tolist(), gravity_moment.tolist()
    tanh, sin, cos, exp = math.tanh, math.sin, math.cos, math.exp
    two_pi = 2.0 * math.pi
    for i in range(n_steps):
        torque = ff[i] + kp * (q_ref[i] - q_m) + kd * (w_ref[i] - w_m)
        deflection = q_m - q_l
        if deflection > backlash:
            transmitted = stiffness * (deflection - backlash) + damping * (w_m - w_l)
        elif deflection < -backlash:
            transmitted = stiffness * (deflection + backlash) + damping * (w_m - w_l)
        else:
            transmitted = 0.0
        motor_angle = gear_ratio * q_m
        direction = tanh(w_m / stribeck_speed)
        load = coulomb * direction + viscous * w_m + ripple * sin(mesh * motor_angle)
        if stribeck:
            load += stribeck * exp(-((w_m / stribeck_speed) ** 2)) * direction
        if tooth:
            gear = (motor_angle / stage_ratio - damaged_at) % two_pi
            gear = gear - two_pi if gear > math.pi else gear
            if -half_tooth < gear < half_tooth:
                load += tooth * direction * 0.5 * (1 + cos(math.pi * gear / half_tooth))
        if bearing:
            pulse = 0.5 * (1 + cos(bearing_order * motor_angle))
            load += bearing * direction * pulse**3 * (0.6 + 0.4 * cos(motor_angle))
        out_qm[i], out_wm[i], out_ql[i], out_tau[i], out_ts[i] = q_m, w_m, q_l, torque, transmitted
        a_m = (torque - transmitted - load) / j_motor
        a_l = (transmitted - g_moment[i] * cos(q_l)) / j_link[i]
        w_m += a_m * dt
        w_l += a_l * dt
        q_m += w_m * dt
        q_l += w_l * dt
    keep = slice(n_warm, None)
    return _Trajectory(
        time_s[keep] - time_s[n_warm],
        out_qm[keep],
        out_wm[keep],
        out_ql[keep],
        out_tau[keep],
        out_ts[keep],
        ref.position[keep],
    )


def _resolve_task(task: Task | str) -> Task:
    if isinstance(task, Task):
        return task
    if task not in TASKS:
        raise ValueError(f"Unknown task {task!r}; expected a Task or one of {sorted(TASKS)}.")
    return TASKS[task]


def simulate_capture(
    task: Task | str,
    *,
    fault: Fault | None = None,
    duration_s: float = 3.0,
    phase_s: float | None = None,
    seed: int | np.random.Generator | None = 0,
    metadata: Mapping[str, str] | None = None,
    spec: AxisSpec = NOMINAL_AXIS,
) -> Capture:
    """Simulate one capture of a robot axis doing ``task``, possibly with a developing fault.

    Parameters
    ----------
    task : Task or str
        A :class:`Task` or the name of one of :data:`TASKS`.
    fault : Fault, optional
        Mechanical fault and its severity; healthy when None.
    duration_s : float, default=3.0
        Capture length in seconds (at least 0.1).
    phase_s : float, optional
        Time into the task cycle at which the capture starts; drawn uniformly from one cycle
        (with ``seed``) when None, as a logger that does not know the task would capture.
    seed : int, Generator or None, default=0
        Seeds the phase and the sensor noise.
    metadata : mapping of str to str, optional
        Added to (and overriding) the capture's metadata ``task``, ``fault``, ``severity``,
        ``phase_s``.
    spec : AxisSpec, default=NOMINAL_AXIS
        The axis (a robot family's draw: :func:`~axiswatch.draw_axis`). With a temperature
        coefficient, the capture's temperature is drawn (with ``seed``) in 20-40 degC.

    Returns
    -------
    Capture
        Signals ``position`` (``spec.position_rate_hz``, 250 Hz by default), ``speed`` and
        ``torque`` (``spec.fast_rate_hz``, 2 kHz), ``start_s=0``.

    Examples
    --------
    >>> cap = simulate_capture("heavy", fault=Fault("bearing", 0.5), seed=1)
    >>> {name: cap.signals[name].size for name in cap.names}
    {'position': 750, 'speed': 6000, 'torque': 6000}
    >>> cap.metadata["task"], cap.metadata["fault"]
    ('heavy', 'bearing')
    """
    resolved = _resolve_task(task)
    if not (isinstance(duration_s, int | float) and duration_s >= 0.1):
        raise ValueError(
            f"The 'duration_s' parameter must be a float >= 0.1 (seconds). Got {duration_s!r} instead."
        )
    rng = np.random.default_rng(seed)
    if phase_s is None:
        phase_s = float(rng.uniform(0.0, resolved.cycle_s))
    # Drawn only for an axis whose friction depends on it, so that the original axis's captures
    # keep their random streams.
    temperature_c = float(rng.uniform(20.0, 40.0)) if spec.temperature_coefficient else 30.0
    trajectory = _simulate_axis(
        resolved, fault, float(duration_s), float(phase_s), spec, temperature_c
    )
    for rate in (spec.fast_rate_hz, spec.position_rate_hz):
        if INTEGRATION_RATE_HZ % rate:
            raise ValueError(
                f"The logging rates of AxisSpec must divide {INTEGRATION_RATE_HZ:g} Hz. "
                f"Got {rate!r} instead."
            )
    fast = round(INTEGRATION_RATE_HZ / spec.fast_rate_hz)
    n_fast = round(duration_s * spec.fast_rate_hz)
    speed = trajectory.motor_speed[::fast][:n_fast]
    torque = trajectory.motor_torque[::fast][:n_fast]
    slow = round(INTEGRATION_RATE_HZ / spec.position_rate_hz)
    position = trajectory.motor_position[::slow][: round(duration_s * spec.position_rate_hz)]
    signals = {
        "position": position + rng.normal(scale=spec.noise_position, size=position.size),
        "speed": speed + rng.normal(scale=spec.noise_speed, size=speed.size),
        "torque": torque + rng.normal(scale=spec.noise_torque, size=torque.size),
    }
    for name, quantum in (("position", spec.position_quantum), ("torque", spec.torque_quantum)):
        if quantum > 0:
            signals[name] = np.round(signals[name] / quantum) * quantum
    labels = {
        "task": resolved.name,
        "fault": fault.kind if fault is not None else "none",
        "severity": f"{fault.severity if fault is not None else 0.0:g}",
        "phase_s": f"{phase_s:.6f}",
    }
    if spec.temperature_coefficient:
        labels["temperature_c"] = f"{temperature_c:.2f}"
    labels.update(metadata or {})
    return Capture(
        signals,
        {
            "position": spec.position_rate_hz,
            "speed": spec.fast_rate_hz,
            "torque": spec.fast_rate_hz,
        },
        source=f"simulated {resolved.name}",
        metadata=labels,
    )
