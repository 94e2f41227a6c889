"""A family of simulated robot axes: each robot draws its own mechanics, controller and logger.

:func:`draw_robot` turns a seed into a :class:`SimulatedRobot`. The seeds split once into
:data:`DEVELOPMENT_ROBOTS` and :data:`HELD_OUT_ROBOTS`. See docs/internals.md, "The robot family".
"""

from __future__ import annotations

import dataclasses
import math
import zlib
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

import numpy as np

from axiswatch._capture import Capture
from axiswatch.datasets._robot import (
    INTEGRATION_RATE_HZ,
    NOMINAL_AXIS,
    AxisSpec,
    Fault,
    Task,
    simulate_capture,
)

__all__ = [
    "DEVELOPMENT_ROBOTS",
    "HELD_OUT_ROBOTS",
    "UNIT_FIELDS",
    "SimulatedRobot",
    "draw_robot",
    "draw_unit",
    "unit_factors",
]

#: Seeds of the robots on which every parameter of a method is chosen.
DEVELOPMENT_ROBOTS: tuple[int, ...] = tuple(range(8))

#: Seeds of the robots that are only reported, never used for a choice.
HELD_OUT_ROBOTS: tuple[int, ...] = tuple(range(1000, 1012))

#: Logging rates a robot draws from (Hz); each divides the integration rate.
FAST_RATES_HZ: tuple[float, ...] = (20.0, 50.0, 100.0, 250.0, 500.0, 1000.0, 2000.0, 4000.0)

#: Capture length of every task but the strokes (s): longer than the longest drawn cycle (3.6 s).
CAPTURE_S = 4.0

#: The AxisSpec fields in which units of one robot model differ (:func:`draw_unit`).
UNIT_FIELDS: tuple[str, ...] = ("coulomb", "viscous", "backlash", "stiffness", "damping", "j_motor")

FrictionFault = Literal["coulomb", "viscous", "both"]
_FRICTION_FAULTS: tuple[FrictionFault, ...] = ("coulomb", "viscous", "both")


@dataclass(frozen=True)
class SimulatedRobot:
    """One drawn robot axis, its tasks and how its faults develop.

    Attributes
    ----------
    seed : int
    kind : {"arm", "wrist"}
        An arm axis holds its link (and payload) against gravity; a wrist axis hardly does.
    spec : AxisSpec
    tasks : tuple of Task
        Six tasks; the last is logged as one-direction strokes (:meth:`capture`).
    friction_fault : {"coulomb", "viscous", "both"}
        Which friction term the robot's friction fault grows.
    """

    seed: int
    kind: Literal["arm", "wrist"]
    spec: AxisSpec
    tasks: tuple[Task, ...]
    friction_fault: FrictionFault

    @property
    def name(self) -> str:
        """``robot<seed>``."""
        return f"robot{self.seed}"

    @property
    def stroke_task(self) -> str:
        """Name of the task logged one stroke (one direction) at a time."""
        return self.tasks[-1].name

    def capture(
        self,
        task: int | str,
        *,
        fault: Fault | None = None,
        seed: int | str = 0,
        metadata: Mapping[str, str] | None = None,
    ) -> Capture:
        """One capture of ``task`` (index or name) at a random phase; the stroke task's capture
        starts with a move, in a random direction, and ends before the next one.

        ``seed`` (an int or any string) seeds the phase, temperature and noise, mixed with the
        robot's seed.
        """
        chosen = self.tasks[task] if isinstance(task, int) else self._task(task)
        mixed = zlib.crc32(f"{self.seed}/{chosen.name}/{seed}".encode())
        rng = np.random.default_rng(mixed)
        phase: float | None = None
        duration = CAPTURE_S
        if chosen.name == self.stroke_task:
            back = bool(rng.integers(2))
            phase = chosen.move_s + chosen.dwell_place_s if back else 0.0
            duration = chosen.move_s + (chosen.dwell_pick_s if back else chosen.dwell_place_s)
        labels = {"robot": self.name, "task": chosen.name, **(metadata or {})}
        return simulate_capture(
            chosen,
            fault=fault,
            duration_s=duration,
            phase_s=phase,
            seed=rng,
            metadata=labels,
            spec=self.spec,
        )

    def _task(self, name: str) -> Task:
        for task in self.tasks:
            if task.name == name:
                return task
        raise ValueError(
            f"Unknown task {name!r} of {self.name}; expected one of {[t.name for t in self.tasks]}."
        )


def _log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(math.exp(rng.uniform(math.log(low), math.log(high))))


def _rates(rng: np.random.Generator) -> tuple[float, float]:
    fast = float(rng.choice(FAST_RATES_HZ))
    slower = [
        fast / k
        for k in (1, 2, 4, 8)
        if fast / k >= 20.0 and (INTEGRATION_RATE_HZ / (fast / k)).is_integer()
    ]
    return float(rng.choice(slower)), fast


def _tasks(rng: np.random.Generator, kind: str, size: float) -> tuple[Task, ...]:
    tasks = []
    for k in range(6):
        amplitude = rng.uniform(0.3, 1.5) if kind == "arm" else rng.uniform(0.5, 3.0)
        move = rng.uniform(0.35, 1.2)
        cruise = float(rng.uniform(0.4, 0.8)) if k in (1, 3) or rng.uniform() < 0.2 else 0.0
        payload = rng.uniform(0.0, 10.0) * size if kind == "arm" else rng.uniform(0.0, 5.0)
        tasks.append(
            Task(
                f"task{k}",
                float(amplitude),
                float(move),
                float(rng.uniform(0.1, 0.6)),
                float(rng.uniform(0.1, 0.6)),
                float(payload),
                float(rng.uniform(-0.5, 1.2)),
                cruise,
            )
        )
    return tuple(tasks)


def draw_robot(seed: int) -> SimulatedRobot:
    """Draw one robot axis of the family (deterministic in ``seed``).

    Ranges (about the project's original axis, :data:`~axiswatch.NOMINAL_AXIS`): size factor
    0.3-3 (arm) or 0.05-0.5 (wrist) scaling inertias, friction, stiffness and gains together;
    gear ratio 50-160 with a tooth stage of 3-7.5 motor turns and 17-40 teeth; bearing defect
    order 3.5-7.5; Coulomb x 0.5-1.5, viscous x 0.3-2, Stribeck peak 0-50 % of Coulomb, friction
    falling 0.5-2 % per kelvin; stiffness x 0.5-2; torque rate 20 Hz-4 kHz with the position at
    that rate or 2, 4, 8 times slower (never below 20 Hz); encoder of 12-20 bits; torque
    resolution 0, 0.1 or 1 % of Coulomb friction; noise x 0.3-3.

    Examples
    --------
    >>> robot = draw_robot(3)
    >>> robot.name, len(robot.tasks), robot.spec.fast_rate_hz >= 20
    ('robot3', 6, True)
    >>> draw_robot(3) == robot
    True
    """
    rng = np.random.default_rng(zlib.crc32(f"axiswatch robot family/{seed}".encode()))
    kind: Literal["arm", "wrist"] = "arm" if rng.uniform() < 0.6 else "wrist"
    size = _log_uniform(rng, 0.3, 3.0) if kind == "arm" else _log_uniform(rng, 0.05, 0.5)
    gear_ratio = float(rng.choice([50.0, 80.0, 100.0, 120.0, 160.0]))
    coulomb = NOMINAL_AXIS.coulomb * size * rng.uniform(0.5, 1.5)
    friction_fault = _FRICTION_FAULTS[int(rng.integers(len(_FRICTION_FAULTS)))]
    growth = {"coulomb": (3.0, 0.0), "viscous": (0.0, 2.5), "both": (2.0, 1.5)}[friction_fault]
    position_rate, fast_rate = _rates(rng)
    bits = int(rng.choice([12, 14, 16, 20]))
    spec = AxisSpec(
        gear_ratio=gear_ratio,
        mesh_order=float(rng.choice([1.0, 2.0])),
        tooth_stage_ratio=float(rng.choice([3.0, 4.0, 5.0, 6.0, 7.5])),
        tooth_count=int(rng.integers(17, 41)),
        bearing_order=float(rng.uniform(3.5, 7.5)),
        j_motor=NOMINAL_AXIS.j_motor * size * rng.uniform(0.7, 1.3),
        j_link=NOMINAL_AXIS.j_link * size * rng.uniform(0.7, 1.3),
        arm_m=float(rng.uniform(0.6, 1.4) if kind == "arm" else rng.uniform(0.05, 0.2)),
        link_moment=NOMINAL_AXIS.link_moment
        * size
        * (rng.uniform(0.5, 1.5) if kind == "arm" else rng.uniform(0.0, 0.05)),
        stiffness=NOMINAL_AXIS.stiffness * size * _log_uniform(rng, 0.5, 2.0),
        damping=NOMINAL_AXIS.damping * size * rng.uniform(0.7, 1.3),
        backlash=NOMINAL_AXIS.backlash * rng.uniform(0.5, 2.0),
        coulomb=coulomb,
        viscous=NOMINAL_AXIS.viscous * size * rng.uniform(0.3, 2.0),
        stribeck_speed=float(rng.uniform(0.01, 0.05)),
        stribeck_peak=coulomb * rng.uniform(0.0, 0.5),
        temperature_coefficient=-float(rng.uniform(0.005, 0.02)),
        ripple=NOMINAL_AXIS.ripple * size * rng.uniform(0.3, 1.5),
        kp=NOMINAL_AXIS.kp * size * rng.uniform(0.6, 1.5),
        kd=NOMINAL_AXIS.kd * size * rng.uniform(0.7, 1.3),
        position_rate_hz=position_rate,
        fast_rate_hz=fast_rate,
        position_quantum=2 * math.pi / 2**bits / gear_ratio,
        torque_quantum=coulomb * float(rng.choice([0.0, 0.001, 0.01])),
        noise_position=NOMINAL_AXIS.noise_position * _log_uniform(rng, 0.3, 3.0),
        noise_speed=NOMINAL_AXIS.noise_speed * _log_uniform(rng, 0.3, 3.0),
        noise_torque=NOMINAL_AXIS.noise_torque * size * _log_uniform(rng, 0.3, 3.0),
        tooth_impact=coulomb * rng.uniform(2.0, 4.0),
        bearing_impact=coulomb * rng.uniform(0.8, 1.6),
        coulomb_growth=growth[0] * rng.uniform(0.8, 1.2),
        viscous_growth=growth[1] * rng.uniform(0.8, 1.2),
        backlash_growth=float(rng.uniform(3e-3, 8e-3)),
    )
    return SimulatedRobot(seed, kind, spec, _tasks(rng, kind, size), friction_fault)


def unit_factors(robot_seed: int, unit: int, spread: float) -> dict[str, float]:
    """Lognormal factors ``exp(spread * z)``, ``z ~ N(0, 1)``, one per field of
    :data:`UNIT_FIELDS`, for unit ``unit`` of the robot model ``robot_seed``.

    ``z`` is drawn from a seed mixed from (``robot_seed``, ``unit``) only, so a unit keeps its
    deviations' directions at every ``spread`` (a sensitivity study compares like with like);
    ``spread`` is the factors' log standard deviation (0.1: about 10 % between units); at 0
    every factor is exactly 1.

    Examples
    --------
    >>> unit_factors(3, 0, 0.0)["coulomb"]
    1.0
    >>> a, b = unit_factors(3, 0, 0.1), unit_factors(3, 0, 0.2)
    >>> bool(abs(math.log(b["stiffness"]) - 2 * math.log(a["stiffness"])) < 1e-12)
    True
    """
    if not (math.isfinite(spread) and spread >= 0.0):
        raise ValueError(f"The 'spread' of unit_factors must be a float >= 0. Got {spread!r}.")
    rng = np.random.default_rng(zlib.crc32(f"axiswatch unit/{robot_seed}/{unit}".encode()))
    z = rng.standard_normal(len(UNIT_FIELDS))
    return {name: math.exp(spread * float(zk)) for name, zk in zip(UNIT_FIELDS, z, strict=True)}


def draw_unit(robot: SimulatedRobot, unit: int, spread: float) -> SimulatedRobot:
    """One unit of ``robot``'s model: its :class:`~axiswatch.AxisSpec` with the fields of
    :data:`UNIT_FIELDS` multiplied by :func:`unit_factors` (log standard deviation ``spread``).

    What differs between units of one robot model, by manufacturing tolerance and wear-in:
    motor-side Coulomb friction (the Stribeck peak, drawn as a share of it, scales with it, so
    the friction law keeps its shape) and viscous friction, the gearbox's backlash, stiffness
    and damping, and the motor's inertia (rotor and brake tolerances). What a model shares and
    is left alone: the kinematics (gear ratio, mesh order, tooth stage and count, bearing
    order), the link (inertia, lever, gravity moment: one casting and one payload), the
    lubricant's Stribeck speed and temperature coefficient, the ripple, the controller's gains,
    logging rates, quantisation and noise, and how faults grow and strike. The unit keeps the
    robot's seed and tasks, so :meth:`SimulatedRobot.capture` with the same task and ``seed``
    draws the same phase, temperature and noise on every unit: units differ in their physics
    only, not in their random draws. The simulator's feed-forward uses the spec it is given, so
    each unit's controller knows its own friction and inertia (as if identified at
    commissioning).

    Examples
    --------
    >>> robot = draw_robot(3)
    >>> draw_unit(robot, 0, 0.0) == robot
    True
    >>> unit = draw_unit(robot, 0, 0.1)
    >>> unit.spec.gear_ratio == robot.spec.gear_ratio, unit.spec.coulomb != robot.spec.coulomb
    (True, True)
    """
    factors = unit_factors(robot.seed, unit, spread)
    changed = {name: getattr(robot.spec, name) * f for name, f in factors.items()}
    changed["stribeck_peak"] = robot.spec.stribeck_peak * factors["coulomb"]
    return dataclasses.replace(robot, spec=dataclasses.replace(robot.spec, **changed))
