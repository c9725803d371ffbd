"""A double-acting hydraulic cylinder fed by a proportional 4/3 directional valve: the
first force element with states of its own (its two chamber pressures).

Geometry: the cylinder acts along the line from ``marker_a`` (the barrel's mount) to
``marker_b`` (the rod eye); its length l, stroke s = l - ``length_retracted`` (0 retracted,
``stroke`` extended) and stroke rate s' = dl/dq . q'. Piston area A_a = pi D^2 / 4 (bore D),
annulus A_b = A_a - pi d^2 / 4 (rod d). Chamber volumes, each with its dead and hose volume:

    V_a = V_a0 + A_a s,    V_b = V_b0 + A_b (stroke - s).

Pressures (Pa, gauge) p_a, p_b are the element's states, from the oil's compressibility
(effective bulk modulus beta, hoses and walls included):

    p_a' = beta / V_a (Q_a - A_a s' - Q_L),    p_b' = beta / V_b (Q_b + A_b s' + Q_L),

with the leakage across the piston Q_L = c_L (p_a - p_b). Oil carrying undissolved air
(``air_content`` alpha: its volume fraction at atmospheric pressure p0) is softer at low
pressure: the air, compressed isothermally beside the oil, gives the mixture the effective
modulus at absolute pressure P = p + p0

    beta_e(P) = beta (1 + alpha p0 / P) / (1 + alpha beta p0 / P^2),

beta at high pressure and far less near the tank's (1 % air, beta = 1 GPa: 0.99 beta at
100 bar, 0.55 beta at 10 bar, 0.08 beta at 2 bar gauge), used in every chamber's rate (and
the supply line's). The air stays undissolved unless ``air_dissolved_pressure`` p_d
(gauge) is given: then it dissolves as the pressure rises, the undissolved share of it
x(p) = 1 - 3 s^2 + 2 s^3, s = p / p_d, from atmospheric pressure (x = 1) to p_d (x = 0;
a cubic with zero slope at both ends, so the modulus is continuous: equilibrium
dissolution, taken as instant and reversible), and the mixture of the oil and the air
left, alpha x p0 / P of it per unit of oil, has the modulus

    beta_e(P) = beta (1 + x y) / (1 + beta y (x / P - x')),   y = alpha p0 / P,

x' = dx/dp (the air dissolving adds its own compliance), beta from p_d up. The valve's command u(t) in
[-1, 1] (``command``; clipped) sets its spool position x: at once (x = u), or through spool
dynamics, a first-order lag (``spool_time_constant`` tau: x' = (u - x) / tau) or a
second-order one (``spool_frequency`` f_v, ``spool_damping`` zeta_v: x'' = w_v^2 (u - x) -
2 zeta_v w_v x', w_v = 2 pi f_v), x (and x') then being states of the element too. The
spool opens P->A and B->T for x > 0, P->B and A->T for x < 0, each metering edge a
sharp-edged orifice whose opening is a(x) = clip((x - o) / (1 - o), 0, 1) for the edges x
opens (and a(-x) for the others), o the ``spool_overlap`` as a fraction of the travel
(0: zero lap; o > 0: a dead band of +-o; o < 0: underlap, every edge open by -o / (1 - o)
at centre, the oil passing P->A->T and P->B->T):

    Q = K a f(dp),  K = Q_nom / sqrt(dp_nom),  f(dp) = dp / (dp^2 + dp_L^2)^(1/4),

so f = sign(dp) sqrt(|dp|) (turbulent) above the ``laminar_drop`` dp_L and f ~ dp / sqrt(dp_L)
(laminar) below it: the regularisation keeps dQ/dp finite at dp = 0, where the square root
has an infinite slope that stalls Newton. Supply at ``supply_pressure`` (a constant-pressure
pump), return to ``tank_pressure``. Or, with ``pump_flow`` Q_p given, a pump of that flow
feeds a supply line of volume V_s (``supply_volume``) whose pressure p_s is a third state,
guarded by a relief valve that opens at ``relief_pressure`` (flow ``relief_gain`` times the
excess, smoothed over 0.1 bar):

    p_s' = beta / V_s (Q_p - Q_PA - Q_PB - Q_relief(p_s)).

A load-holding (counterbalance) valve (``counterbalance``) may sit between one chamber
(side a or b) and the directional valve's port: the line between them, of volume V_c at
pressure p_c, is one more state, and the valve passes

    Q_cb = K_cb (f(max(p_c - p, 0)) - a f(p - p_c)),
    a = clip((p + psi p_pilot - p_set) / dp_open, 0, 1),

into the chamber (p its pressure): freely in through its check valve, out only where the
chamber's pressure plus the pilot ratio psi times the other chamber's (the pilot, which
the directional valve raises to lower the load) exceeds the setting p_set, fully open
over dp_open. So an overrunning load is held against an open directional valve and
lowered at the pace the pilot meters; p_c' = beta / V_c (Q_port - Q_cb). Its spool opens
at once (a as above), or, with a ``time_constant`` tau_o (and a ``closing_time_constant``
tau_c), lags behind: the opening is then one more state, a' = (a_s - a) / tau, a_s the
clipped opening above and tau = tau_o while it opens (a_s > a), tau_c while it closes (a
damping orifice on the pilot slows a real valve's opening more than its closing). Or,
with a ``spool_frequency`` f_c (and ``spool_damping`` zeta_c), the spool is a mass on its
spring: a'' = w_c^2 (a_s - a) - 2 zeta_c w_c a', w_c = 2 pi f_c, its opening and rate two
states. The seat and the stop act through a_s (clipped to [0, 1]: the spring and pilot
forces beyond them are carried by the housing) and through the orifice, which passes
clip(a, 0, 1): a spool that overshoots them transiently is not stopped there (no impact).
Such a valve can hunt: lowering an overrunning load, its opening and the load's motion
may feed each other into a sustained oscillation where the spool is lightly damped.

Force pushing the markers apart: F = p_a A_a - p_b A_b - c s' - F_c tanh(s' / v_s) (seal
friction, viscous and Coulomb; the Coulomb part smoothed over ``friction_velocity`` v_s),
and with ``end_stiffness`` k_e the end stops: a stroke beyond [0, stroke] by a depth d
meets -sign k_e d (1 + c_e d') (Hunt and Crossley: the damping ``end_damping`` c_e, s/m,
grows with the depth, so the force is continuous at contact and the rebound loses energy
as a real stop does).
The element is non-conservative: its power F s' enters the energy balance as work done on
the machine (the ``dissipated`` entry, with its sign: negative where the cylinder lifts).

The command may come from a controller on the cylinder (``command=PID(...)``): a PID
law with output limits and anti-windup by back-calculation (Astrom & Hagglund) on the
cylinder's own stroke, on a joint coordinate, on a marker's position in ground axes (a
bucket's height, a boom tip's reach: "marker:link.frame:x|y|z", its rate from dP/dq q')
or on one of its chamber pressures (``measured``; a pressure loop has no derivative term),

    e = r(t) - y,   v = k_ff r'(t) + k_p e + x_i - k_d y',   u = clip(v, u_min, u_max),
    x_i' = k_i e + (u - v) / T_t,

its integral term x_i (output units) one more state of the element (``pid``); the
derivative acts on the measurement (no kick when the reference jumps) and the tracking
time T_t defaults to sqrt(T_i T_d) (T_i = k_p / k_i, T_d = k_d / k_p; T_i without k_d).
The feed-forward k_ff r' opens the valve for the reference's own rate (k_ff ~ A / Q_u, the
area over the valve's flow per unit command), so the loop need not lag to move.

Not modelled (yet): the cushions' throttling near the ends (without end stops a stroke
outside [0, stroke] is reported by the run's checks), cavitation (pressures below -1 bar
gauge are reported), the time the air takes to dissolve and to come out again (taken as
instant), a counterbalance spool's impacts on its seat and stop.

The physics (flows, pressure rates, force) is written once, as the compiled functions
below; the element's methods evaluate them (:class:`~pipeline.dynamics.forces.base.
CompiledElement`), and the numpy oracle is ``tests/dynamics/forces_numpy.py``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any, ClassVar

import numpy as np
from numba import njit

from pipeline.core import kernel_cache  # noqa: F401  (numba's cache kept consistent)
from pipeline.core.errors import ConfigError
from pipeline.dynamics.forces.base import CompiledElement, Kernels, LineElement
from pipeline.dynamics.forces.markers import line_geometry, marker_point, no_potential
from pipeline.kinematics.marker_names import marker_component

__all__ = ["PID", "CounterbalanceValve", "HydraulicCylinder", "anti_windup_time", "check_gains", "cylinder_push",
           "cylinder_rates", "marker_measurement", "pid_law"]

#: bar: the scale of a pressure state (Newton's and the error estimate's units)
PRESSURE_UNIT = 1e5
#: the chamber pressures a controller may measure, in the order of the states
PRESSURES = ("p_a", "p_b")

# par columns of the packed element
_AA, _AB, _L0, _STROKE, _VA0, _VB0, _BETA, _PS, _PT, _KV, _DPL, _LEAK, _VISC, _COUL, _VS, \
    _QP, _PR, _KR, _VS0, _SPOOL, _TAU, _WV, _ZV, _OVL, _KE, _CE, _AIR, _PDIS, \
    _CBS, _KCB, _PSET, _PSI, _DPO, _VC0, _TCO, _TCC, _CBW, _CBZ, \
    _PID, _KP, _KI, _KD, _UMIN, _UMAX, _TT, _MEAS, _KFF, _MMK, _MCOMP = range(49)
#: Pa: atmospheric pressure, the reference of the gauge pressures and of the air content
ATMOSPHERE = 101325.0
#: _MEAS of a controller on a marker's position (its point _MMK, its component _MCOMP)
_ON_MARKER = -4


def _number(x, above: float = -math.inf, at_least: float = -math.inf) -> bool:
    """Is x a finite real number (not a bool) above ``above`` and at least ``at_least``?"""
    return not isinstance(x, bool) and isinstance(x, int | float) and math.isfinite(x) \
        and x > above and x >= at_least
def marker_measurement(measured: str) -> tuple[str, str, int] | None:
    """(link, frame, axis 0..2) of a ``measured`` "marker:link.frame:x|y|z", None for any
    other signal; a ConfigError for a malformed one.

    >>> marker_measurement("marker:boom.tip:y")
    ('boom', 'tip', 1)
    >>> marker_measurement("stroke") is None
    True
    """
    if not measured.startswith("marker:"):
        return None
    try:
        link, frame, axis, _ = marker_component(measured[len("marker:"):])
    except ValueError as exc:
        raise ConfigError(f"PID: measured: marker: {exc} (a marker's position in ground "
                          f"axes)") from None
    return link, frame, axis


@dataclass(frozen=True)
class PID:
    """A PID controller commanding a hydraulic cylinder's valve (the module docstring):
    ``reference`` r(t) (a number, a driver or a table: m for the stroke, the coordinate's
    unit otherwise), gains ``kp`` (1 per unit of y), ``ki`` (per unit and second), ``kd``
    (per unit per second), on ``measured`` ("stroke": the cylinder's own, m; "p_a" or
    "p_b": its chamber pressure, Pa, without a derivative term; a joint coordinate's
    name; or "marker:link.frame:x|y|z", a marker's position in ground axes, m), output
    limited to ``output_limits`` (the valve's [-1, 1] by
    default), anti-windup ``tracking_time`` T_t, s (None: the rule of the docstring), and
    ``feedforward`` k_ff, the command per unit/s of the reference's rate."""

    reference: Any
    kp: float
    ki: float = 0.0
    kd: float = 0.0
    measured: str = "stroke"
    output_limits: tuple = (-1.0, 1.0)
    tracking_time: float | None = None
    feedforward: float = 0.0

    def __post_init__(self):
        check_gains(self, "PID")
        lo = self.output_limits
        if not (isinstance(lo, tuple | list) and len(lo) == 2
                and all(isinstance(x, int | float) and not isinstance(x, bool) for x in lo)
                and -1.0 <= lo[0] < lo[1] <= 1.0):
            raise ConfigError(f"PID: output_limits: expected [u_min, u_max] within the "
                              f"valve's [-1, 1], u_min < u_max, got {lo!r}")
        tt = self.tracking_time
        if tt is not None and (isinstance(tt, bool) or not isinstance(tt, int | float)
                               or not tt > 0 or not math.isfinite(tt)):
            raise ConfigError(f"PID: tracking_time: expected seconds > 0, got {tt!r}")
        if not isinstance(self.measured, str) or not self.measured:
            raise ConfigError(f"PID: measured: expected 'stroke', 'p_a', 'p_b', a "
                              f"coordinate's name or 'marker:link.frame:x|y|z', got "
                              f"{self.measured!r}")
        marker_measurement(self.measured)
        if self.measured in PRESSURES and self.kd:
            raise ConfigError(f"PID: kd: a loop on the pressure {self.measured} has no "
                              f"derivative term (the pressure's rate is the state "
                              f"equation's own); give kd 0")

    def value(self, t: float) -> float:
        """The reference r(t): the history the compiled step evaluates once per step."""
        from pipeline.dynamics.forces.loads import history_value

        return history_value(self.reference, t, "PID reference")

    def rate(self, t: float) -> float:
        """The reference's rate r'(t) (0 for a number or a held value)."""
        from pipeline.dynamics.forces.loads import history_rate

        return history_rate(self.reference, t)

    def values_at(self, times: np.ndarray) -> np.ndarray:
        """r at each of ``times`` (k,) s (at once for a driver)."""
        from pipeline.dynamics.forces.loads import history_values

        return history_values(self.reference, times, "PID reference")

    def rates_at(self, times: np.ndarray) -> np.ndarray:
        """r' at each of ``times`` (k,) s."""
        from pipeline.dynamics.forces.loads import history_rates

        return history_rates(self.reference, times)

    @property
    def tracking(self) -> float:
        """T_t, s (0: no integral action, nothing to wind up): :func:`anti_windup_time`."""
        return anti_windup_time(self.kp, self.ki, self.kd, self.tracking_time)


def check_gains(controller, what: str) -> None:
    """A ConfigError naming ``what`` and the field unless the ``controller``'s kp, ki, kd
    and feedforward are finite numbers >= 0 (this module's PID and the sampled one)."""
    for key in ("kp", "ki", "kd", "feedforward"):
        x = getattr(controller, key)
        if not _number(x, at_least=0.0):
            raise ConfigError(f"{what}: {key}: expected a gain >= 0, got {x!r}")


def anti_windup_time(kp: float, ki: float, kd: float, given: float | None = None) -> float:
    """The back-calculation's tracking time T_t, s, of a PID (this module's, and the
    sampled one beside the machine, :class:`pipeline.solver.cosim.SampledPID`): ``given``,
    else sqrt(T_i T_d) with T_i = k_p / k_i and T_d = k_d / k_p (Astrom & Hagglund), T_i
    without a derivative term; 0 without integral action (nothing winds up).

    >>> anti_windup_time(20.0, 40.0, 0.5)  # sqrt(0.5 * 0.025)
    0.11180339887498948
    """
    if not ki:
        return 0.0
    if given is not None:
        return float(given)
    ti = kp / ki
    return math.sqrt(ti * kd / kp) if kd and kp else ti or 1.0


@dataclass(frozen=True)
class CounterbalanceValve:
    """A load-holding (counterbalance) valve between a cylinder's chamber on ``side``
    ("a" or "b") and the directional valve's port (module docstring): a check valve lets
    oil into the chamber freely; out of it the valve opens only where the chamber's
    pressure plus ``pilot_ratio`` times the other chamber's (the pilot) exceeds
    ``setting`` (Pa), fully over ``opening_range`` (Pa). Flow through it: ``nominal_flow``
    (m^3/s) at ``nominal_drop`` (Pa), fully open. The line between the two valves holds
    ``line_volume`` (m^3) at ``initial_pressure`` (Pa gauge) at the start.

    Its spool follows its pilot at once (None), or with a first-order lag: the opening a
    is then a state, a' = (a_s - a) / tau, a_s the opening its pressures call for (module
    docstring), tau ``time_constant`` (s) while it opens (a_s > a) and
    ``closing_time_constant`` (s; default the same) while it closes: a real valve's
    damping orifice slows its opening more than its closing. Or as a mass on its spring,
    of natural frequency ``spool_frequency`` (Hz) and damping ratio ``spool_damping``:
    a'' = w^2 (a_s - a) - 2 zeta w a', the opening and its rate then states."""

    side: str
    setting: float
    pilot_ratio: float = 3.0
    nominal_flow: float = 1e-3
    nominal_drop: float = 10e5
    opening_range: float = 10e5
    line_volume: float = 1e-4
    initial_pressure: float = 0.0
    time_constant: float | None = None
    closing_time_constant: float | None = None
    spool_frequency: float | None = None
    spool_damping: float = 0.7

    def __post_init__(self):
        if self.side not in ("a", "b"):
            raise ConfigError(f"counterbalance: side: expected 'a' (the piston side) or 'b' "
                              f"(the rod side), got {self.side!r}")
        for key in ("setting", "nominal_flow", "nominal_drop", "opening_range",
                    "line_volume"):
            x = getattr(self, key)
            if not _number(x, above=0.0):
                raise ConfigError(f"counterbalance: {key}: expected a number > 0, got {x!r}")
        for key in ("pilot_ratio", "initial_pressure"):
            x = getattr(self, key)
            if not _number(x, at_least=0.0 if key == "pilot_ratio" else -math.inf):
                raise ConfigError(f"counterbalance: {key}: expected a finite number"
                                  f"{' >= 0' if key == 'pilot_ratio' else ''}, got {x!r}")
        for key in ("time_constant", "closing_time_constant"):
            x = getattr(self, key)
            if x is not None and not _number(x, above=0.0):
                raise ConfigError(f"counterbalance: {key}: expected seconds > 0 (or none: "
                                  f"the spool follows its pilot at once), got {x!r}")
        for key in ("spool_frequency", "spool_damping"):
            x = getattr(self, key)
            if (x is not None or key == "spool_damping") and not _number(x, above=0.0):
                raise ConfigError(f"counterbalance: {key}: expected a number > 0 (or none "
                                  f"for the frequency: the spool follows its pilot at "
                                  f"once), got {x!r}")
        if self.closing_time_constant is not None and self.time_constant is None:
            raise ConfigError("counterbalance: closing_time_constant: the spool has no "
                              "dynamics without time_constant (its opening lag); give "
                              "time_constant too")
        if self.time_constant is not None and self.spool_frequency is not None:
            raise ConfigError("counterbalance: spool_frequency: give the spool a first-order "
                              "lag (time_constant) or a second-order one (spool_frequency, "
                              "spool_damping), not both")

    @property
    def spool_order(self) -> int:
        """0: the spool follows its pilot at once; 1: a first-order lag; 2: a mass on its
        spring (the opening, and its rate, are states)."""
        return 2 if self.spool_frequency is not None else \
            1 if self.time_constant is not None else 0

    @property
    def lagged(self) -> bool:
        """Is the spool's opening a state (it lags behind its pilot)?"""
        return self.spool_order > 0

    def parameters(self) -> list[float]:
        """(side 1 or 2, K = Q_nom / sqrt(dp_nom), setting, pilot ratio, opening range,
        line volume, opening and closing time constants (0 without a lag), the spool's
        natural angular frequency (rad/s; 0 without) and damping ratio): the packed
        element's counterbalance columns."""
        tau = self.time_constant or 0.0
        return [1.0 if self.side == "a" else 2.0,
                self.nominal_flow / math.sqrt(self.nominal_drop), self.setting,
                self.pilot_ratio, self.opening_range, self.line_volume, tau,
                self.closing_time_constant or tau, 2 * math.pi * (self.spool_frequency or 0.0),
                self.spool_damping]


@dataclass(frozen=True)
class HydraulicCylinder(CompiledElement, LineElement):
    """Hydraulic cylinder with a 4/3 proportional valve (module docstring). SI units:
    m, m^3, Pa, m^3/s, N, s.

    ``dead_volume_a``/``_b`` default to 10 % of the chamber's full volume (add the
    hoses'); ``air_content`` is the volume fraction of undissolved air in the oil at
    atmospheric pressure (0: the constant ``bulk_modulus``; module docstring), all of it
    dissolved from ``air_dissolved_pressure`` (Pa gauge; None: it stays undissolved) up;
    ``counterbalance`` a :class:`CounterbalanceValve` (or its fields as a mapping) on one
    chamber;
    ``initial_pressures`` (Pa gauge) are the states at the start, one of them
    possibly ``"hold"``: the pressure that, with the other, holds the machine at rest
    where it starts (a loaded boom on a closed valve).
    """

    name: str
    marker_a: tuple[str, str]
    marker_b: tuple[str, str]
    bore: float
    rod: float
    stroke: float
    length_retracted: float
    supply_pressure: float
    nominal_flow: float
    nominal_drop: float = 35e5
    tank_pressure: float = 0.0
    bulk_modulus: float = 1.0e9
    dead_volume_a: float | None = None
    dead_volume_b: float | None = None
    leakage: float = 0.0
    viscous_friction: float = 0.0
    coulomb_friction: float = 0.0
    friction_velocity: float = 1e-3
    laminar_drop: float = 1e5
    initial_pressures: tuple = (0.0, 0.0)
    command: Any = 0.0
    pump_flow: float | None = None
    relief_pressure: float | None = None
    relief_gain: float = 1e-9
    supply_volume: float = 1e-3
    initial_supply_pressure: float = 0.0
    spool_time_constant: float | None = None
    spool_frequency: float | None = None
    spool_damping: float = 0.7
    spool_overlap: float = 0.0
    end_stiffness: float | None = None
    end_damping: float = 0.0
    air_content: float = 0.0
    air_dissolved_pressure: float | None = None
    counterbalance: Any = None
    KIND: ClassVar[int] = 8
    TYPE: ClassVar[str] = "hydraulic_cylinder"
    HISTORY: ClassVar[str] = "command"

    @property
    def spool_order(self) -> int:
        """0: the spool follows the command at once; 1 or 2: the order of its dynamics."""
        return 2 if self.spool_frequency is not None else \
            1 if self.spool_time_constant is not None else 0

    def state_layout(self) -> tuple[tuple[str, str, float], ...]:
        """(name, unit, scale) of each of the element's own states, in the order its
        compiled rates read and write them (``_state_count`` and ``command_rates``):
        the chamber pressures p_a, p_b; the supply line's p_s when a pump of given flow
        feeds it; a counterbalance valve's line p_c and, lagged, its opening a_c (and,
        second order, its rate v_c); the
        spool's position x_v (and rate v_v) when it has dynamics; a controller's integral.
        Scales: a bar for a pressure, the valve's full opening, the spool's whole travel
        (and, second order, that per 1 / w_v). STATES, STATE_UNITS and state_scales are
        its columns."""
        bar = ("Pa", PRESSURE_UNIT)
        rows = [("p_a", *bar), ("p_b", *bar)]
        if self.pump_flow is not None:
            rows.append(("p_s", *bar))
        if self.counterbalance is not None:
            rows.append(("p_c", *bar))
        if self.counterbalance_lagged:
            rows += [("a_c", "1", 1.0), ("v_c", "1/s", 2 * math.pi * (
                self.counterbalance.spool_frequency or 0.0))][:self.counterbalance.spool_order]
        rows += [("x_v", "1", 1.0),
                 ("v_v", "1/s", 2 * math.pi * (self.spool_frequency or 0.0))][:self.spool_order]
        if self.controlled:
            rows.append(("pid", "1", 1.0))
        return tuple(rows)

    @property
    def STATES(self) -> tuple[str, ...]:
        """The states' names (:meth:`state_layout`)."""
        return tuple(r[0] for r in self.state_layout())

    @property
    def STATE_UNITS(self) -> tuple[str, ...]:
        return tuple(r[1] for r in self.state_layout())

    @property
    def counterbalance_lagged(self) -> bool:
        """Has the cylinder a counterbalance valve whose opening is a state (a_c)?"""
        return self.counterbalance is not None and self.counterbalance.lagged

    @property
    def controlled(self) -> bool:
        """Is the valve commanded by a controller on the cylinder (:class:`PID`)?"""
        return isinstance(self.command, PID)

    def __post_init__(self):
        where = f"force element '{self.name}'"
        for key in ("bore", "stroke", "length_retracted", "bulk_modulus", "nominal_drop",
                    "friction_velocity", "laminar_drop"):
            x = getattr(self, key)
            if not _number(x, above=0.0):
                raise ConfigError(f"{where}: {key}: expected a number > 0, got {x!r}")
        for key in ("rod", "supply_pressure", "nominal_flow", "leakage", "viscous_friction",
                    "coulomb_friction"):
            x = getattr(self, key)
            if not _number(x, at_least=0.0):
                raise ConfigError(f"{where}: {key}: expected a number >= 0, got {x!r}")
        a = self.air_content
        if isinstance(a, bool) or not isinstance(a, int | float) or not 0.0 <= a < 1.0:
            raise ConfigError(f"{where}: air_content: expected a volume fraction in [0, 1) "
                              f"(undissolved air at atmospheric pressure, e.g. 0.01), got "
                              f"{a!r}")
        d = self.air_dissolved_pressure
        if d is not None:
            if isinstance(d, bool) or not isinstance(d, int | float) or not d > 0 \
                    or not math.isfinite(d):
                raise ConfigError(f"{where}: air_dissolved_pressure: expected a gauge "
                                  f"pressure > 0 Pa (all the air dissolved from it up), got "
                                  f"{d!r}")
            if not a:
                raise ConfigError(f"{where}: air_dissolved_pressure: there is no air to "
                                  f"dissolve (air_content is 0); give air_content, or leave "
                                  f"air_dissolved_pressure out")
        cb = self.counterbalance
        if isinstance(cb, Mapping):
            try:
                cb = CounterbalanceValve(**cb)
            except TypeError:
                from dataclasses import fields

                names = [f.name for f in fields(CounterbalanceValve)]
                unknown = sorted(set(cb) - set(names))
                what = f"unknown field {unknown[0]!r}" if unknown else \
                    f"missing field(s) {sorted({'side', 'setting'} - set(cb))}"
                raise ConfigError(f"{where}: counterbalance: {what}; its fields: {names} "
                                  f"(side and setting needed)") from None
            except ConfigError as exc:
                raise ConfigError(f"{where}: {exc}") from None
            object.__setattr__(self, "counterbalance", cb)
        elif cb is not None and not isinstance(cb, CounterbalanceValve):
            raise ConfigError(f"{where}: counterbalance: expected a CounterbalanceValve or "
                              f"its fields, got {type(cb).__name__}")
        if not self.rod < self.bore:
            raise ConfigError(f"{where}: rod: expected a diameter below the bore "
                              f"({self.bore} m), got {self.rod}")
        for key in ("dead_volume_a", "dead_volume_b"):
            x = getattr(self, key)
            if x is not None and not _number(x, above=0.0):
                raise ConfigError(f"{where}: {key}: expected a volume > 0 m^3, got {x!r}")
        p = self.initial_pressures
        if not (isinstance(p, tuple | list) and len(p) == 2 and list(p).count("hold") <= 1
                and all(x == "hold" or (isinstance(x, int | float) and not isinstance(x, bool)
                                        and math.isfinite(x)) for x in p)):
            raise ConfigError(f"{where}: initial_pressures: expected [p_a, p_b] in Pa, one of "
                              f"them may be 'hold' (found so that the machine starts at "
                              f"rest), got {p!r}")
        if self.pump_flow is not None:
            for key in ("pump_flow", "relief_pressure", "relief_gain", "supply_volume"):
                x = getattr(self, key)
                if not _number(x, above=0.0):
                    raise ConfigError(f"{where}: {key}: a pump of given flow needs a number "
                                      f"> 0 here, got {x!r}")
        for key in ("spool_time_constant", "spool_frequency", "spool_damping"):
            x = getattr(self, key)
            if x is not None and not _number(x, above=0.0):
                raise ConfigError(f"{where}: {key}: expected a number > 0, got {x!r}")
        if self.spool_time_constant is not None and self.spool_frequency is not None:
            raise ConfigError(f"{where}: spool_frequency: give the spool a first-order lag "
                              f"(spool_time_constant) or a second-order one "
                              f"(spool_frequency, spool_damping), not both")
        for key in ("end_stiffness", "end_damping"):
            x = getattr(self, key)
            if x is not None and not _number(x, at_least=0.0):
                raise ConfigError(f"{where}: {key}: expected a number >= 0, got {x!r}")
        o = self.spool_overlap
        if isinstance(o, bool) or not isinstance(o, int | float) or not -1.0 < o < 1.0:
            raise ConfigError(f"{where}: spool_overlap: expected a fraction of the spool's "
                              f"travel in (-1, 1) (negative: underlap), got {o!r}")
        if not isinstance(self.tank_pressure, int | float) or \
                not self.tank_pressure <= self.supply_pressure:
            raise ConfigError(f"{where}: tank_pressure: expected a number at most the supply "
                              f"pressure, got {self.tank_pressure!r}")

    # ------------------------------------------------------------------ data
    @property
    def areas(self) -> tuple[float, float]:
        """(piston area A_a, annulus area A_b), m^2."""
        a = 0.25 * math.pi * self.bore ** 2
        return a, a - 0.25 * math.pi * self.rod ** 2

    @property
    def dead_volumes(self) -> tuple[float, float]:
        """(V_a0, V_b0), m^3."""
        aa, ab = self.areas
        return (0.1 * aa * self.stroke if self.dead_volume_a is None else self.dead_volume_a,
                0.1 * ab * self.stroke if self.dead_volume_b is None else self.dead_volume_b)

    def parameters(self) -> np.ndarray:
        """(49,) the packed parameters (the ``par`` row of the compiled form)."""
        aa, ab = self.areas
        va, vb = self.dead_volumes
        pump = self.pump_flow is not None
        return np.array([aa, ab, self.length_retracted, self.stroke, va, vb,
                         self.bulk_modulus, self.supply_pressure, self.tank_pressure,
                         self.nominal_flow / math.sqrt(self.nominal_drop), self.laminar_drop,
                         self.leakage, self.viscous_friction, self.coulomb_friction,
                         self.friction_velocity, self.pump_flow if pump else 0.0,
                         self.relief_pressure if pump else 0.0, self.relief_gain,
                         self.supply_volume, self.spool_order,
                         self.spool_time_constant or 0.0,
                         2 * math.pi * (self.spool_frequency or 0.0), self.spool_damping,
                         self.spool_overlap, self.end_stiffness or 0.0, self.end_damping,
                         self.air_content, self.air_dissolved_pressure or 0.0,
                         *(self.counterbalance.parameters() if self.counterbalance is not None
                           else [0.0] * 10),
                         *self._pid_parameters()], dtype=float)

    def _pid_parameters(self) -> tuple:
        """(flag, kp, ki, kd, u_min, u_max, T_t, the measured signal (-1 here: the packing
        and the numpy rates set it from the mechanism, measured_index), k_ff, a measured
        marker's point (set by the packing) and axis) of the packed element."""
        c = self.command
        if not self.controlled:
            return (0.0,) * 7 + (-1.0, 0.0, 0.0, 0.0)
        on = marker_measurement(c.measured)
        return (1.0, c.kp, c.ki, c.kd, *map(float, c.output_limits), c.tracking, -1.0,
                c.feedforward, 0.0, float(on[2]) if on else 0.0)

    def with_input(self, history) -> HydraulicCylinder:
        """The valve command set from outside; with a controller, its reference."""
        if self.controlled:
            return replace(self, command=replace(self.command, reference=history))
        return super().with_input(history)

    def measured_index(self, mech) -> int:
        """The measured coordinate's index; -1 for the stroke, -2 and -3 for the pressures
        p_a and p_b, -4 for a marker's position (ConfigError naming the element for an
        unknown coordinate, link or frame)."""
        if not self.controlled or self.command.measured == "stroke":
            return -1
        if self.command.measured in PRESSURES:
            return -2 - PRESSURES.index(self.command.measured)
        try:
            on = marker_measurement(self.command.measured)
            if on is not None:
                mech.marker(on[0], on[1])  # the link and its frame exist
                return _ON_MARKER
            return mech.index(self.command.measured)
        except ConfigError as exc:
            raise ConfigError(f"force element '{self.name}': command: measured: {exc}") \
                from None

    def validate(self, system) -> None:
        super().validate(system)
        self.measured_index(system.mechanism)

    def chamber_volumes(self, s: float) -> tuple[float, float]:
        """(V_a, V_b) at stroke s (m), m^3: dead volume plus the swept one."""
        aa, ab = self.areas
        va, vb = self.dead_volumes
        return va + aa * s, vb + ab * (self.stroke - s)

    def oil_stiffness(self, s: float, pressures=(0.0, 0.0)) -> float:
        """The oil columns' axial stiffness beta_a A_a^2 / V_a + beta_b A_b^2 / V_b at
        stroke s (m), valve closed, N/m; with air in the oil the moduli are the effective
        ones at the chambers' ``pressures`` (p_a, p_b), Pa gauge."""
        aa, ab = self.areas
        va, vb = self.chamber_volumes(s)
        par = self.parameters()
        return effective_bulk_modulus(par, pressures[0]) * aa ** 2 / va \
            + effective_bulk_modulus(par, pressures[1]) * ab ** 2 / vb

    def pack(self, mech, markers) -> tuple:
        """(ints, par, table rows or None) of the compiled form."""
        par = self.parameters()
        par[_MEAS] = self.measured_index(markers.mech)
        if par[_MEAS] == _ON_MARKER:
            par[_MMK] = markers.add(marker_measurement(self.command.measured)[:2])
        return ([markers.add(self.marker_a), markers.add(self.marker_b), 0, 0], list(par),
                None)

    def initial_states(self) -> np.ndarray:
        """The states (:meth:`state_layout`) at the start: pressures in
        Pa, NaN for a ``hold`` pressure (found at the start so that the machine is at
        rest: pipeline.dynamics.held_states); a lagged counterbalance valve open as the
        start pressures call for (closed on a held chamber; a second-order spool at rest
        there); the spool at rest where the
        command at t = 0 puts it."""
        from pipeline.dynamics.forces.loads import history_value

        p = [np.nan if x == "hold" else x for x in self.initial_pressures]
        if self.pump_flow is not None:
            p.append(self.initial_supply_pressure)
        cb = self.counterbalance
        if cb is not None:
            p.append(cb.initial_pressure)
        if self.counterbalance_lagged:  # open as its start pressures call for; a held
            # chamber's valve is closed (it holds)
            pc, pilot = (p[0], p[1]) if cb.side == "a" else (p[1], p[0])
            p.append(0.0 if np.isnan(pc) or np.isnan(pilot) else
                     counterbalance_opening(self.parameters(), float(pc), float(pilot)))
            p += [0.0][:cb.spool_order - 1]
        if self.spool_order:  # a controller's spool starts centred
            u = 0.0 if self.controlled else \
                min(max(history_value(self.command, 0.0, self.name), -1.0), 1.0)
            p += [u, 0.0][:self.spool_order]
        if self.controlled:
            p.append(0.0)  # the integral term
        return np.array(p, dtype=float)

    def state_scales(self) -> np.ndarray:
        """The states' scales (:meth:`state_layout`)."""
        return np.array([r[2] for r in self.state_layout()])

    def stroke_at(self, system, q) -> float:
        """The stroke s (m) at coordinates q (n,): the markers' distance less
        ``length_retracted``."""
        from pipeline.dynamics.forces.base import marker_pose
        from pipeline.kinematics import evaluate_tree

        tree = evaluate_tree(system.mechanism, q, derivatives=False)
        a, b = (marker_pose(system, *m, tree, q)[:3, 3] for m in (self.marker_a, self.marker_b))
        return float(np.linalg.norm(b - a)) - self.length_retracted

    def sealed_pressure(self, p0: float, ratio: float) -> float:
        """The pressure (Pa gauge) of oil sealed at p0 (Pa gauge) once its volume is
        ``ratio`` times what it was: dp = -beta_e(p) dV / V integrated, in closed form,
        ln(V / V0) = -[(P - P0) / beta + ln(P / P0) - (1 + a / beta) ln((P + a) / (P0 + a))]
        with P the absolute pressures and a = alpha p0 (module docstring; without air,
        p0 - beta ln(ratio)), solved for P; with the air dissolving, ln(V / V0) =
        -int dp / beta_e(p) by quadrature."""
        beta, alpha = self.bulk_modulus, self.air_content
        if alpha == 0.0:
            return p0 - beta * math.log(ratio)
        from scipy.optimize import brentq

        if self.air_dissolved_pressure is not None:  # the integral, by quadrature
            from scipy.integrate import quad

            par = self.parameters()
            pd = self.air_dissolved_pressure

            def compliance(p):
                return 1.0 / effective_bulk_modulus(par, p)

            def integral(p):
                lo, hi = min(p0, p), max(p0, p)
                kinks = [x for x in (0.0, pd) if lo < x < hi]
                return math.copysign(quad(compliance, lo, hi, points=kinks or None,
                                          epsabs=0.0, epsrel=1e-13, limit=200)[0],
                                     p - p0)

            return brentq(lambda p: math.log(ratio) + integral(p),
                          1e-6 * ATMOSPHERE - ATMOSPHERE, p0 + 100.0 * beta, xtol=1e-9,
                          rtol=1e-14)
        a, P0 = alpha * ATMOSPHERE, p0 + ATMOSPHERE

        def residual(p):
            P = p + ATMOSPHERE
            return math.log(ratio) + (P - P0) / beta + math.log(P / P0) \
                - (1.0 + a / beta) * math.log((P + a) / (P0 + a))

        return brentq(residual, 1e-6 * ATMOSPHERE - ATMOSPHERE, p0 + 100.0 * beta,
                      xtol=1e-9, rtol=1e-14)

    def trapped_states(self, system, q_ref, z_ref, t: float = 0.0):
        """The element's states as a function of q (n,) -> (k,), sealed at z_ref (k,) at
        q_ref (n,): behind the closed valve each chamber's oil is compressed or relieved
        by the stroke (:meth:`sealed_pressure` of its volume's ratio); the other states
        (a supply or counterbalance line, the spool, a controller) keep theirs. A
        ConfigError where the valve is open at t (its command beyond the spool's overlap)
        or a controller commands it."""
        from pipeline.dynamics.forces.loads import history_value

        where = f"force element '{self.name}': trapped"
        if self.controlled:
            raise ConfigError(f"{where}: a controller commands its valve: the oil is not "
                              f"trapped")
        u = history_value(self.command, t, self.name)
        if abs(u) > max(self.spool_overlap, 0.0):
            raise ConfigError(f"{where}: its valve is open at t = {t:g} s (command {u:g}); "
                              f"the oil is trapped behind a closed valve only")
        z_ref = self.own_states(z_ref)
        ref = self.chamber_volumes(self.stroke_at(system, q_ref))

        def states(q):
            z = z_ref.copy()
            for k, v in enumerate(self.chamber_volumes(self.stroke_at(system, q))):
                z[k] = self.sealed_pressure(float(z_ref[k]), v / ref[k])
            return z
        return states

    def run_checks(self, system, r) -> list[str]:
        """What the model leaves out and a run ``r`` (SimulationResult) reached: a stroke
        outside [0, stroke] (no end stops yet) or a pressure below -1 bar gauge
        (cavitation, not modelled: the pressure goes on falling)."""
        out = []
        if not r.t.size:
            return out
        # every pressure of the element: the lower chamber's, a pump's supply line's, a
        # counterbalance valve's line's
        lines = {"p_s": "the supply line's", "p_c": "the counterbalance valve's line"}
        for names in (("p_a", "p_b"), ("p_s",), ("p_c",)):
            keys = [f"{self.name}.{x}" for x in names]
            if keys[0] not in r.state_names:
                continue
            i = r.state_names.index(keys[0])
            p = r.states[:, i:i + len(keys)]
            k, j = np.unravel_index(int(np.argmin(p)), p.shape)
            if p[k, j] < -1e5:
                what, remedy = ((f"the {'ab'[j]}-side pressure", "that chamber")
                                if len(names) == 2 else (f"{lines[names[0]]} pressure",
                                                         "that line"))
                out.append(f"hydraulic cylinder '{self.name}': {what} fell to "
                           f"{p[k, j] / 1e5:.3g} bar gauge at t = {r.t[k]:.4g} s; oil "
                           f"cavitates near -1 bar, which the model leaves out (feed "
                           f"{remedy} more flow, or move slower)")
        worst = (0.0, 0.0, 0.0)
        for k in np.unique(np.linspace(0, r.t.size - 1, min(r.t.size, 200)).astype(int)):
            s = self.stroke_at(system, r.q[k])
            beyond = max(-s, s - self.stroke)
            if beyond > worst[0]:
                worst = (beyond, s, float(r.t[k]))
        if self.end_stiffness:
            if worst[0] > 0.05 * self.stroke:
                out.append(f"hydraulic cylinder '{self.name}': its stroke reached "
                           f"{worst[1]:.4g} m at t = {worst[2]:.4g} s, {worst[0]:.3g} m into "
                           f"its end stop (beyond 5 % of the stroke): end_stiffness "
                           f"{self.end_stiffness:g} N/m is too soft for this load")
        elif worst[0] > 1e-3 * self.stroke:
            out.append(f"hydraulic cylinder '{self.name}': its stroke reached {worst[1]:.4g} m "
                       f"at t = {worst[2]:.4g} s, outside [0, {self.stroke:g}] m; without end "
                       f"stops (end_stiffness) the motion beyond is not the machine's")
        return out


# ---------------------------------------------------------------------- the physics, once
@njit(cache=True)
def _orifice(dp, laminar):
    """dp / (dp^2 + dp_L^2)^(1/4): sign(dp) sqrt|dp| turbulent, linear below dp_L."""
    return dp / (dp * dp + laminar * laminar) ** 0.25


@njit(cache=True)
def effective_bulk_modulus(par, p):
    """The oil's bulk modulus (Pa) at gauge pressure p (Pa) with its entrained air (module
    docstring): beta (1 + alpha p0 / P) / (1 + alpha beta p0 / P^2), P = p + p0 (absolute,
    kept above a hundredth of an atmosphere: below, the oil cavitates, which the run's
    checks report); with the air dissolving, of its undissolved share x(p)."""
    alpha = par[_AIR]
    if alpha == 0.0:
        return par[_BETA]
    x, dx = 1.0, 0.0  # the air's undissolved share and its rate, 1/Pa
    pd = par[_PDIS]
    if pd > 0.0 and p > 0.0:
        if p >= pd:
            return par[_BETA]
        s = p / pd
        x = 1.0 - s * s * (3.0 - 2.0 * s)
        dx = -6.0 * s * (1.0 - s) / pd
    P = max(p + ATMOSPHERE, 0.01 * ATMOSPHERE)
    y = alpha * ATMOSPHERE / P
    return par[_BETA] * (1.0 + x * y) / (1.0 + par[_BETA] * y * (x / P - dx))


@njit(cache=True)
def piston_force(par, pa, pb, s, sd):
    """Force pushing the markers apart, N, at the pressures pa, pb (Pa), stroke s (m) and
    stroke rate sd (m/s): pressures on the areas less the seal friction, and the end
    stops' (module docstring)."""
    f = pa * par[_AA] - pb * par[_AB] - par[_VISC] * sd - par[_COUL] * np.tanh(sd / par[_VS])
    if par[_KE] > 0.0:
        if s < 0.0:  # below the retracted end: pushed out
            f += par[_KE] * -s * (1.0 - par[_CE] * sd)
        elif s > par[_STROKE]:  # beyond the extended end: pulled in
            f -= par[_KE] * (s - par[_STROKE]) * (1.0 + par[_CE] * sd)
    return f


@njit(cache=True)
def relief_flow(par, ps):
    """Flow (m^3/s) through the relief valve at the supply pressure ps (Pa): the gain
    times the excess over the cracking pressure, smoothed over 0.1 bar."""
    x = (ps - par[_PR]) / 1e4
    soft = x if x > 30.0 else np.log1p(np.exp(x))  # softplus: max(x, 0), smooth
    return par[_KR] * 1e4 * soft


@njit(cache=True)
def opening(par, x):
    """The opening (0..1) of the metering edges the spool position x opens (module
    docstring: its overlap o, clipped travel); a(-x) is the other edges'."""
    o = par[_OVL]
    return min(max((min(max(x, -1.0), 1.0) - o) / (1.0 - o), 0.0), 1.0)


@njit(cache=True)
def spool_acceleration(w, zeta, target, x, v):
    """x'' of a spool that is a mass on its spring (the directional valve's, a
    counterbalance valve's): w^2 (target - x) - 2 zeta w x', at its natural angular
    frequency w (rad/s) and damping ratio zeta."""
    return w * w * (target - x) - 2.0 * zeta * w * v


@njit(cache=True)
def valve_rates(par, u, length, sd, z, o, zd):
    """zd[o:] = the rates of the element's states z[o:] (module docstring: pressures, the
    supply line's, the spool's) at the command u, length (m) and stroke rate sd (m/s)."""
    pump = 1 if par[_QP] > 0.0 else 0
    cb = 1 if par[_CBS] > 0.0 else 0
    lag = counterbalance_order(par)  # the counterbalance valve's opening (and rate)
    c = o + 2 + pump  # the counterbalance line's state, then its opening's
    k = c + cb + lag  # the spool's states
    order = int(par[_SPOOL])
    x = u if order == 0 else z[k]
    out = np.empty(6)
    pressure_rates(par, length, sd, z[o], z[o + 1], z[o + 2] if pump else 0.0,
                   z[c] if cb else 0.0, z[c + 1] if lag else 0.0,
                   z[c + 2] if lag == 2 else 0.0, x, out)
    zd[o], zd[o + 1] = out[0], out[1]
    if pump:
        zd[o + 2] = out[2]
    if cb:
        zd[c] = out[3]
    if lag:
        zd[c + 1] = out[4]
    if lag == 2:
        zd[c + 2] = out[5]
    u = min(max(u, -1.0), 1.0)
    if order == 1:
        zd[k] = (u - z[k]) / par[_TAU]
    elif order == 2:
        zd[k] = z[k + 1]
        zd[k + 1] = spool_acceleration(par[_WV], par[_ZV], u, z[k], z[k + 1])


@njit(cache=True)
def pid_law(par, r, rd, y, yd, xi):
    """(the valve command u, the integral term's rate x_i') of the controller (module
    docstring) at the reference r and its rate rd, measurement y and its rate yd,
    integral term xi."""
    v = par[_KFF] * rd + par[_KP] * (r - y) + xi - par[_KD] * yd
    u = min(max(v, par[_UMIN]), par[_UMAX])
    rate = 0.0
    if par[_KI] > 0.0:
        rate = par[_KI] * (r - y) + (u - v) / par[_TT]
    return u, rate


@njit(cache=True)
def command_rates(par, command, rate, length, sd, ym, ymd, q, v, z, o, zd):
    """zd[o:] = the rates of the element's states z[o:] at the valve ``command`` (the
    history's value; with a controller, its reference, and ``rate`` its rate), length (m),
    stroke rate sd (m/s), a measured marker's position component ym (m) and its rate ymd
    (m/s), and coordinates q, rates v (a controller's measurement)."""
    if par[_PID] > 0.0:
        k = o + _state_count(par) - 1  # the integral term: the element's last state
        i = int(par[_MEAS])
        if i >= 0:
            y, yd = q[i], v[i]
        elif i == -1:
            y, yd = length - par[_L0], sd
        elif i == _ON_MARKER:
            y, yd = ym, ymd
        else:  # a chamber pressure, kd = 0
            y, yd = z[o - 2 - i], 0.0
        u, zd[k] = pid_law(par, command, rate, y, yd, z[k])
        valve_rates(par, u, length, sd, z, o, zd)
    else:
        valve_rates(par, command, length, sd, z, o, zd)


@njit(cache=True)
def _state_count(par) -> int:
    """The element's number of states (STATES)."""
    return 2 + (1 if par[_QP] > 0.0 else 0) + (1 if par[_CBS] > 0.0 else 0) \
        + counterbalance_order(par) + int(par[_SPOOL]) + (1 if par[_PID] > 0 else 0)


@njit(cache=True)
def counterbalance_order(par) -> int:
    """The counterbalance spool's states: 0 (it follows its pilot at once), 1 (a lag) or 2
    (a mass on its spring)."""
    return 1 if par[_TCO] > 0.0 else 2 if par[_CBW] > 0.0 else 0


@njit(cache=True)
def counterbalance_opening(par, pc, pilot):
    """The opening a_s = clip((pc + psi pilot - p_set) / dp_open, 0, 1) the chamber's
    pressure pc and the ``pilot`` (Pa) call for (module docstring)."""
    return min(max((pc + par[_PSI] * pilot - par[_PSET]) / par[_DPO], 0.0), 1.0)


@njit(cache=True)
def counterbalance_flow(par, pc, pl, a):
    """Flow (m^3/s) from the line (pressure pl, Pa) into the chamber (pc) through the
    counterbalance valve at its opening ``a`` (module docstring): the check valve's
    K f(max(pl - pc, 0)) less the relief's K a f(pc - pl)."""
    lam = par[_DPL]
    return par[_KCB] * (_orifice(max(pl - pc, 0.0), lam) - a * _orifice(pc - pl, lam))


@njit(cache=True)
def counterbalance_lag(par, a, target):
    """a' (1/s) of a lagged counterbalance valve's opening a towards ``target`` (its
    opening time constant while it opens, its closing one while it closes)."""
    return (target - a) / (par[_TCO] if target > a else par[_TCC])


@njit(cache=True)
def pressure_rates(par, length, sd, pa, pb, psup, pc, ac, vc, x, out):
    """out (6,) = (p_a', p_b', p_s', p_c', a_c', v_c'), Pa/s, 1/s and 1/s^2, at the length
    (m), stroke rate sd (m/s), pressures pa, pb, with a pump of given flow the supply
    line's psup, with a counterbalance valve its line's pc (Pa) and, lagged, its opening ac
    (unused where it opens at once) and, second order, its rate vc (1/s), and spool
    position x (module docstring); p_s' (p_c', a_c', v_c') is 0 without that pump (valve,
    lag, second order)."""
    s = length - par[_L0]
    up, un = opening(par, x), opening(par, -x)
    pump = par[_QP] > 0.0
    ps = psup if pump else par[_PS]
    pt, lam = par[_PT], par[_DPL]
    side = int(par[_CBS])
    # the directional valve's work ports: the chambers', or the counterbalance line's
    wa = pc if side == 1 else pa
    wb = pc if side == 2 else pb
    qpa, qpb = up * _orifice(ps - wa, lam), un * _orifice(ps - wb, lam)
    qa = par[_KV] * (qpa - un * _orifice(wa - pt, lam))
    qb = par[_KV] * (qpb - up * _orifice(wb - pt, lam))
    out[3] = out[4] = out[5] = 0.0
    lag = counterbalance_order(par)
    # a second-order spool may overshoot its seat or stop: the orifice opens within them
    a = min(max(ac, 0.0), 1.0)
    target = 0.0
    if side == 1:  # port A feeds the line; the counterbalance valve feeds chamber a
        target = counterbalance_opening(par, pa, pb)
        q = counterbalance_flow(par, pa, pc, a if lag else target)
        out[3] = effective_bulk_modulus(par, pc) / par[_VC0] * (qa - q)
        qa = q
    elif side == 2:
        target = counterbalance_opening(par, pb, pa)
        q = counterbalance_flow(par, pb, pc, a if lag else target)
        out[3] = effective_bulk_modulus(par, pc) / par[_VC0] * (qb - q)
        qb = q
    if side > 0 and lag == 1:
        out[4] = counterbalance_lag(par, ac, target)
    elif side > 0 and lag == 2:
        out[4] = vc
        out[5] = spool_acceleration(par[_CBW], par[_CBZ], target, ac, vc)
    ql = par[_LEAK] * (pa - pb)
    # a stroke beyond the ends (into the end stops, or without them: the run's checks
    # report it) must not empty a chamber: its volume is kept above a tenth of its dead
    # volume
    va = max(par[_VA0] + par[_AA] * s, 0.1 * par[_VA0])
    vb = max(par[_VB0] + par[_AB] * (par[_STROKE] - s), 0.1 * par[_VB0])
    out[0] = effective_bulk_modulus(par, pa) / va * (qa - par[_AA] * sd - ql)
    out[1] = effective_bulk_modulus(par, pb) / vb * (qb + par[_AB] * sd + ql)
    out[2] = 0.0
    if pump:  # the supply line between the pump and the valve
        out[2] = effective_bulk_modulus(par, ps) / par[_VS0] * (
            par[_QP] - par[_KV] * (qpa + qpb) - relief_flow(par, ps))


@njit(cache=True)
def cylinder_push(e, z, length, rate, factor, d):
    """(the piston's force pushing the markers apart, N, all of it non-conservative) at
    the element's pressures z[o:o + 2] and its length (m) and rate (m/s)."""
    o = d.ints[e, 4]
    f = piston_force(d.par[e], z[o], z[o + 1], length - d.par[e, _L0], rate)
    return f, f


@njit(cache=True)
def cylinder_rates(e, q, v, z, A, dA, factor, d, zd):
    length, dl = line_geometry(d.ints[e, 0], d.ints[e, 1], q, A, dA, d)
    par = d.par[e]
    ym = ymd = 0.0
    if par[_PID] > 0.0 and int(par[_MEAS]) == _ON_MARKER:
        n = q.shape[0]
        p, dp = np.zeros(3), np.zeros((n, 3))
        marker_point(int(par[_MMK]), q, A, dA, d, p, dp)
        c = int(par[_MCOMP])
        ym = p[c]
        for i in range(n):
            ymd += dp[i, c] * v[i]
    # factor: the histories' values, then their rates (compiled.force_factors)
    command_rates(par, factor[e], factor[d.kind.shape[0] + e], length, dl @ v, ym, ymd, q, v,
                  z, d.ints[e, 4], zd)


#: the compiled form of this module's kind (:class:`~.base.Kernels`)
KERNELS = (Kernels((HydraulicCylinder,), no_potential, push=cylinder_push, rates=cylinder_rates),)
