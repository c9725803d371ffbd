"""Co-simulation: blocks advanced at a macro step beside the machine, each an FMU (a
controller or a circuit block exported by another tool, FMI 2 or FMI 3, run through fmpy:
co-simulation, or model exchange, whose states this master integrates over each macro
step with its inputs held, locating and handling its state and time events,
:mod:`pipeline.solver.model_exchange`) or a built-in sampled controller
(:class:`SampledPID`, a digital PID's rhythm).

The master loop, at each communication point t_k of the macro step H:

1. every block's inputs are set from the machine's signals at t_k (:func:`signal`: a
   coordinate ``q:<name>``, its rate ``qd:<name>``, an element's state
   ``state:<element>.<state>``, a marker's position ``marker:<link>.<frame>:x|y|z`` or
   ``time``);
2. every block does its step [t_k, t_k + H] (a sampled controller samples when t_k is one
   of its sampling instants, and holds its output between them);
3. its outputs, read after the step, are the machine's inputs over the same interval (a
   :class:`~pipeline.solver.simulator.Simulator` input by name: a force element's history,
   a cylinder's valve command or its controller's reference, a driven coordinate);
4. the machine does its step [t_k, t_k + H].

So the blocks step first on the machine's state at the start of the interval, and hold
their outputs over it: a sampled controller without a delay (a discrete-time controller's
rhythm). The machine's integration error is estimated and judged as the Simulator's
(:meth:`Simulator.result`).

Blocks may feed each other: an input named ``block:<name>.<variable>`` reads block
``<name>``'s output (an FMU's output variable, a sampled PID's ``output``) as it stands
at t_k, from its step to t_k, before any block steps (Jacobi: the order of the blocks does
not matter, and a link between blocks holds over one macro step like a sampled line; at
the initialisation such an input is 0). A controller FMU can so drive a valve or filter
FMU, whose output drives the machine.

The coupling's own error, the block outputs held over each macro step (first order in
H), is estimated too (``coupling_error``): the same co-simulation again from the same start
at H / 2 (fresh block instances, the machine at its own step), compared at the
communication points; the H run's error is taken as twice the difference (first order),
judged against the Simulator's tolerance (rtol, atol), and a run beyond it is "suspect"
with the macro step that would meet it. A built-in sampled controller keeps its own period
at H / 2 (its rhythm is the design, not an error); an FMU cannot say its rhythm (FMI 2
co-simulation has no sampling period), so an FMU that is a digital controller meant to be
sampled at exactly H is compared with itself at H / 2: pass ``coupling_error=False``
there. The estimate costs the co-simulation once more at twice the communication points.
"""

from __future__ import annotations

import ctypes
import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.core.progress import progress_counter
from pipeline.solver.model_exchange import ExchangeFailed

logger = logging.getLogger(__name__)

__all__ = ["BLOCK", "FMU", "SampledPID", "block_names", "cosimulate", "coupling_estimate",
           "signal"]


@dataclass(frozen=True)
class FMU:
    """An FMU (FMI 2 or 3, co-simulation or model exchange) in a co-simulation: its file
    ``path``, its ``inputs``
    ({FMU input variable: the machine's signal}, :func:`signal`), its ``outputs`` ({FMU
    output variable: the Simulator input it drives}) and the start values of its
    ``parameters`` ({variable: value}, set before its initialisation: a number, text
    for a String variable (a file name or a mode, say), bytes or their hex digits for a
    Binary one); ``name``, by which
    other blocks read its outputs (``block:<name>.<variable>``; default ``block<k>``)."""

    path: str | Path
    inputs: Mapping[str, str] = field(default_factory=dict)
    outputs: Mapping[str, str] = field(default_factory=dict)
    parameters: Mapping[str, float | str | bytes] = field(default_factory=dict)
    name: str | None = None

    @property
    def targets(self) -> tuple[str, ...]:
        """The Simulator inputs it drives."""
        return tuple(self.outputs.values())

    def start(self, sim, t0: float, label: str, macro_step: float):
        """The FMU instantiated and initialised for a co-simulation (:class:`_Slave`)."""
        return _Slave(self, sim, t0, label)


@dataclass(frozen=True)
class SampledPID:
    """A digital PID controller beside the machine: every ``period`` T (s) it samples the
    machine's signal ``measured`` (:func:`signal`) and sets the Simulator input ``output``
    (a cylinder's valve command, a force element's history, a driven coordinate) to

        e_k = r(t_k) - y_k,   v_k = k_ff r'(t_k) + k_p e_k + x_k - k_d (y_k - y_k-1) / T,
        u_k = clip(v_k, u_min, u_max),   x_k+1 = x_k + T (k_i e_k + (u_k - v_k) / T_t),

    held over [t_k, t_k + T) (zero-order hold): the derivative acts on the measurement (0 at
    the first sample), the integral is pulled back while the output is clipped
    (back-calculation, T_t by
    :func:`pipeline.dynamics.forces.hydraulics.anti_windup_time`). ``reference`` r(t): a
    number, a driver or a table (its rate r' feeds ``feedforward`` k_ff). Units: the
    output's per the measured signal's. ``name``: by which other blocks read its output
    (``block:<name>.output``; default ``block<k>``)."""

    measured: str
    output: str
    reference: Any
    kp: float
    ki: float = 0.0
    kd: float = 0.0
    period: float = 0.01
    output_limits: tuple[float, float] | None = None
    tracking_time: float | None = None
    feedforward: float = 0.0
    name: str | None = None

    def __post_init__(self):
        from pipeline.dynamics.forces.hydraulics import check_gains

        check_gains(self, "sampled PID")
        for key in ("period", "tracking_time"):
            x = getattr(self, key)
            if (x is not None or key == "period") and (
                    isinstance(x, bool) or not isinstance(x, int | float) or not x > 0
                    or not math.isfinite(x)):
                raise ConfigError(f"sampled PID: {key}: expected seconds > 0, got {x!r}")
        lo = self.output_limits
        if lo is not None and not (isinstance(lo, tuple | list) and len(lo) == 2 and all(
                isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)
                for x in lo) and lo[0] < lo[1]):
            raise ConfigError(f"sampled PID: output_limits: expected [u_min, u_max], "
                              f"u_min < u_max, got {lo!r}")

    @property
    def targets(self) -> tuple[str, ...]:
        """The Simulator input it drives."""
        return (self.output,)

    def start(self, sim, t0: float, label: str, macro_step: float):
        """The running controller (:class:`_Sampler`) of a co-simulation."""
        return _Sampler(self, sim, macro_step)


class _Sampler:
    """A :class:`SampledPID` in a run: its integral term, last measurement and held
    output."""

    def __init__(self, spec: SampledPID, sim, macro_step: float):
        self.spec = spec
        self.where = f"co-simulation: sampled PID on {spec.measured!r}"
        ratio = spec.period / macro_step
        self.every = round(ratio)
        if self.every < 1 or abs(ratio - self.every) > 1e-9 * ratio:
            raise ConfigError(f"{self.where}: period {spec.period:g} s is not a whole "
                              f"multiple of the macro step {macro_step:g} s")
        if spec.output not in sim.inputs:
            raise ConfigError(f"{self.where}: output drives {spec.output!r}, which is not an "
                              f"input of the Simulator (its inputs: {sorted(sim.inputs)}; "
                              "declare it with Simulator(..., inputs=[...]))")
        if not spec.measured.startswith(BLOCK):
            signal(sim, spec.measured)  # an unknown signal: ConfigError before anything runs
        from pipeline.dynamics.forces.hydraulics import anti_windup_time

        self.tracking = anti_windup_time(spec.kp, spec.ki, spec.kd, spec.tracking_time)
        self.k, self.x, self.y_last, self.u = 0, 0.0, None, 0.0

    @property
    def reads(self) -> tuple[str, ...]:
        """The signals it reads."""
        return (self.spec.measured,)

    def exported(self, names) -> list[str]:
        """Its output variables among ``names`` that other blocks may read (its ``output``);
        ConfigError naming the first it does not have."""
        bad = [x for x in names if x != "output"]
        if bad:
            raise ConfigError(f"{self.where}: has no output {bad[0]!r} (a sampled PID's "
                              "is 'output')")
        return list(names)

    def outputs_now(self) -> dict[str, float]:
        return {"output": self.u}

    def step(self, sim, t: float, h: float, linked=None) -> dict[str, float]:
        from pipeline.dynamics.forces.loads import history_rate, history_value

        c = self.spec
        if self.k % self.every == 0:  # a sampling instant
            T = c.period
            y = _read(sim, c.measured, linked)
            e = history_value(c.reference, t, "sampled PID reference") - y
            dy = 0.0 if self.y_last is None else (y - self.y_last) / T
            v = c.feedforward * history_rate(c.reference, t) + c.kp * e + self.x - c.kd * dy
            u = v if c.output_limits is None else min(max(v, c.output_limits[0]),
                                                      c.output_limits[1])
            if c.ki:
                self.x += T * (c.ki * e + (u - v) / self.tracking)
            self.y_last, self.u = y, u
        self.k += 1
        return {c.output: self.u}

    def close(self) -> None:
        pass


#: the prefix of a signal that is another block's output (``block:<name>.<variable>``)
BLOCK = "block:"


def _read(sim, name: str, linked) -> float:
    """Signal ``name``: another block's output from ``linked`` ({name: value}, the master's
    reading at the communication point; 0 before it has one), else the machine's."""
    if name.startswith(BLOCK):
        return float((linked or {}).get(name, 0.0))
    return signal(sim, name)


def signal(sim, name: str) -> float:
    """The machine's signal ``name`` at the Simulator's present state (the module
    docstring's names; SI units)."""
    if name == "time":
        return float(sim.t)
    kind, _, target = name.partition(":")
    coords = sim.coordinates
    if kind in ("q", "qd") and target in coords:
        return float((sim.q if kind == "q" else sim.qd)[coords.index(target)])
    if kind == "state" and target in sim.system.state_names:
        return float(sim.state.z[sim.system.state_names.index(target)])
    if kind == "marker":
        from pipeline.dynamics.forces.base import marker_pose
        from pipeline.kinematics import evaluate_tree
        from pipeline.kinematics.marker_names import marker_component

        try:
            link, frame, axis, _ = marker_component(target)
        except ValueError as exc:
            raise ConfigError(f"co-simulation: signal {name!r}: marker: {exc}") from None
        tree = evaluate_tree(sim.system.mechanism, sim.q, derivatives=False)
        return float(marker_pose(sim.system, link, frame, tree, sim.q)[axis, 3])
    raise ConfigError(
        f"co-simulation: signal {name!r}: expected time, q:<coordinate>, qd:<coordinate> "
        f"(coordinates: {list(coords)}), state:<element>.<state> (states: "
        f"{list(sim.system.state_names)}) or marker:<link>.<frame>:x|y|z")


class _Slave:
    """One FMU instantiated for a run: its value references and its fmpy slave."""

    def __init__(self, spec: FMU, sim, t0: float, label: str):
        try:
            from fmpy import extract, read_model_description
        except ImportError:
            raise ConfigError("co-simulation needs fmpy (pip install fmpy, or the 'fmi' "
                              "extra)") from None
        path = Path(spec.path)
        self.where = f"co-simulation: FMU {str(path)!r}"
        if not path.is_file():
            raise ConfigError(f"{self.where}: no such file")
        try:
            md = read_model_description(str(path))
        except Exception as exc:  # noqa: BLE001 - any unreadable FMU: one line naming it
            raise ConfigError(f"{self.where}: not a readable FMU ({exc})") from None
        self.fmi3 = md.fmiVersion.startswith("3.")
        if not (self.fmi3 or md.fmiVersion.startswith("2.")):
            raise ConfigError(f"{self.where}: FMI {md.fmiVersion}; this master runs FMI 2 "
                              "and FMI 3 FMUs (co-simulation or model exchange)")
        #: a model-exchange FMU: its states integrated here, its events handled
        #: (pipeline.solver.model_exchange)
        self.exchange = md.coSimulation is None
        if self.exchange and md.modelExchange is None:
            raise ConfigError(f"{self.where}: has neither a co-simulation nor a "
                              "model-exchange interface")
        self.me = None
        variables = {v.name: v for v in md.modelVariables}

        def refs(names, causalities, what, text=False):
            out = []
            for name in names:
                v = variables.get(name)
                if v is None:
                    raise ConfigError(f"{self.where}: {what} {name!r}: no such variable; its "
                                      f"variables: {sorted(variables)}")
                if not _usable(v, causalities, text):
                    raise ConfigError(f"{self.where}: {what} {name!r}: expected a number "
                                      f"(Real, Integer, Boolean; FMI 3: Float64, Float32, "
                                      f"Int8-64, UInt8-64, Boolean, Enumeration"
                                      f"{'; or a String, or Binary' if text else ''}) of "
                                      f"causality "
                                      f"{' or '.join(causalities)}, got a {v.type} "
                                      f"{v.causality}")
                out.append(v)
            return out

        # FMI 3 clocks: periodic input clocks of a model-exchange FMU are ticked here; the
        # variables they clock are set (inputs) and read (outputs) at their ticks only
        self.clocked = {v.valueReference for v in md.modelVariables if getattr(v, "clocks", None)}
        self.clocks = _clocks(path, md, self.exchange, self.where)
        self.held_clocked: list = []
        self.clocked_values: dict[int, float] = {}
        self.inputs = list(spec.inputs.items())
        self.outputs = list(spec.outputs.items())
        self.in_vars = refs([k for k, _ in self.inputs], ("input",), "input")
        self.out_vars = refs([k for k, _ in self.outputs], ("output",), "output")
        par_vars = refs(list(spec.parameters), ("parameter", "input"), "parameter", text=True)
        par_values = [_exact(v, x, f"{self.where}: parameter {v.name!r}")
                      for v, x in zip(par_vars, spec.parameters.values())]
        for _, target in self.outputs:
            if target not in sim.inputs:
                raise ConfigError(f"{self.where}: output drives {target!r}, which is not an "
                                  f"input of the Simulator (its inputs: {sorted(sim.inputs)}; "
                                  "declare it with Simulator(..., inputs=[...]))")
        for _, name in self.inputs:
            if not name.startswith(BLOCK):  # (those the master checks against the blocks)
                signal(sim, name)  # an unknown signal: ConfigError before anything runs
        self.variables = variables
        self.export_vars: list = []
        self.export_names: list = []
        self.folder = extract(str(path))
        self.slave, self.started = None, False
        try:
            if self.exchange and self.fmi3:
                from fmpy.fmi3 import FMU3Model as Slave
            elif self.exchange:
                from fmpy.fmi2 import FMU2Model as Slave
            elif self.fmi3:
                from fmpy.fmi3 import FMU3Slave as Slave
            else:
                from fmpy.fmi2 import FMU2Slave as Slave
            interface = md.modelExchange if self.exchange else md.coSimulation
            self.slave = Slave(guid=md.guid, unzipDirectory=self.folder,
                               modelIdentifier=interface.modelIdentifier,
                               instanceName=label)
            self.slave.instantiate()
            if self.fmi3:  # FMI 3: the start time comes with the initialisation
                self.slave.enterInitializationMode(startTime=t0)
            else:
                self.slave.setupExperiment(startTime=t0)
            if par_vars:
                self._set(par_vars, par_values)
            if not self.fmi3:
                self.slave.enterInitializationMode()
            self._set_inputs(sim)
            self.slave.exitInitializationMode()
            self.started = True
            if self.exchange:
                from pipeline.solver.model_exchange import ModelExchange

                self.clocks = _fixed_intervals(
                    self.slave, self.clocks,
                    {v.valueReference: v.name for v in md.modelVariables}, self.where)
                self.me = ModelExchange(self.slave, self.fmi3, md.numberOfContinuousStates,
                                        md.numberOfEventIndicators, self.where, t0,
                                        self.clocks, self._tick_inputs, self._tick_outputs)
        except ConfigError:
            self.close()
            raise
        except ExchangeFailed as exc:
            self.close()
            raise ConfigError(str(exc)) from None
        except Exception as exc:  # noqa: BLE001 - a binary that will not load or start
            self.close()
            raise ConfigError(f"{self.where}: could not be started ({exc})") from None

    def _set(self, variables, values) -> None:
        """Set each variable of ``variables`` to its value (each in its own type)."""
        for v, x in zip(variables, values):
            setter = {"String": "setString", "Binary": "setBinary"}.get(v.type) \
                or _SETTERS[v.type][self.fmi3]
            getattr(self.slave, setter)([v.valueReference], [x])

    def _read_now(self, v) -> float:
        return float(getattr(self.slave, _SETTERS[v.type][self.fmi3].replace("set", "get", 1))(
            [v.valueReference])[0])

    def _get(self, variables) -> list[float]:
        """The values of ``variables`` as floats (a Boolean is 1 or 0); a clocked one's as
        read at its clock's last tick (its start value before)."""
        return [self.clocked_values.get(v.valueReference, _start(v))
                if v.valueReference in self.clocked else self._read_now(v) for v in variables]

    def _set_inputs(self, sim, linked=None) -> None:
        """The inputs from the machine's signals (and other blocks' outputs); a clocked
        one's value is held for its clock's next tick."""
        if self.in_vars:
            values = [(v, _typed(v, _read(sim, name, linked)))
                      for v, (_, name) in zip(self.in_vars, self.inputs)]
            now = [(v, x) for v, x in values if v.valueReference not in self.clocked]
            self.held_clocked = [(v, x) for v, x in values if v.valueReference in self.clocked]
            if now:
                self._set(*zip(*now))

    def _tick_inputs(self, t: float) -> None:
        if self.held_clocked:
            self._set(*zip(*self.held_clocked))

    def _tick_outputs(self) -> None:
        for v in self.out_vars + self.export_vars:
            if v.valueReference in self.clocked:
                self.clocked_values[v.valueReference] = self._read_now(v)

    @property
    def reads(self) -> tuple[str, ...]:
        """The signals it reads."""
        return tuple(name for _, name in self.inputs)

    def exported(self, names) -> list[str]:
        """Make its output variables ``names`` readable by other blocks; ConfigError naming
        the first that is not a numeric output of the FMU."""
        for name in names:
            v = self.variables.get(name)
            if v is None or not _usable(v, ("output",)):
                outs = sorted(k for k, x in self.variables.items() if x.causality == "output")
                raise ConfigError(f"{self.where}: has no output {name!r} for another block "
                                  f"to read (its outputs: {outs})")
            self.export_names.append(name)
            self.export_vars.append(v)
        return list(names)

    def outputs_now(self) -> dict[str, float]:
        """Its exported outputs as they stand (after its last step)."""
        return dict(zip(self.export_names, self._get(self.export_vars)))

    def step(self, sim, t: float, h: float, linked=None) -> dict[str, float]:
        """Its step [t, t + h] on the machine's state at t and the other blocks' outputs
        ``linked``: {Simulator input: value}."""
        self._set_inputs(sim, linked)
        if self.me is not None:
            try:
                self.me.inputs_set(t)
                self.me.advance(t, h)
            except ExchangeFailed as exc:
                raise _StepFailed(str(exc)) from None
        else:
            self._do_step(t, h)
        return {target: x for (_, target), x in zip(self.outputs, self._get(self.out_vars))}

    def _do_step(self, t: float, h: float) -> None:
        """A co-simulation FMU's own step [t, t + h]."""
        try:
            done = self.slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        except Exception as exc:  # noqa: BLE001 - fmpy raises on any status but OK
            raise _StepFailed(f"{self.where}: its step at t = {t:.6g} s failed ({exc})") \
                from None
        if self.fmi3:  # (event handling needed, terminate, early return, last time)
            _, terminate, early, reached = done
            if terminate or early:
                raise _StepFailed(f"{self.where}: its step at t = {t:.6g} s ended at "
                                  f"{reached:.6g} s ({'it asked to terminate' if terminate else 'early return'})")

    def close(self) -> None:
        import shutil

        try:
            # an FMU whose start failed is left as it is: FMI allows it little, and freeing
            # one (pythonfmu's, in this process) corrupted the interpreter's memory
            if self.started:
                self.slave.terminate()
                self.slave.freeInstance()
        except Exception:  # noqa: BLE001,S110 - a failed FMU may refuse to terminate
            pass
        shutil.rmtree(self.folder, ignore_errors=True)


class _StepFailed(Exception):
    pass


#: an FMU variable's type -> (its FMI 2 setter, its FMI 3 setter); getters likewise
_SETTERS = {
    "Real": ("setReal", "setFloat64"), "Integer": ("setInteger", "setInt32"),
    "Boolean": ("setBoolean", "setBoolean"), "Enumeration": ("setInteger", "setInt64"),
    "Float64": (None, "setFloat64"), "Float32": (None, "setFloat32"),
    **{f"{u}Int{b}": (None, f"set{u}Int{b}") for u in ("", "U") for b in (8, 16, 32, 64)},
}
_INTEGERS = {"Integer", "Enumeration"} | {f"{u}Int{b}" for u in ("", "U") for b in (8, 16, 32, 64)}


def _clocks(path: Path, md, exchange: bool, where: str) -> dict[int, tuple[float, float]]:
    """{value reference: (interval, shift), s} of the FMU's clocks: periodic input clocks
    of a constant interval (read from its model description, which fmpy does not parse
    for them) or a fixed one (None here: the FMU gives it after its initialisation,
    :func:`_fixed_intervals`), FMI 3 model exchange; a ConfigError naming any other
    clock."""
    clocks = [v for v in md.modelVariables if v.type == "Clock"]
    if not clocks:
        return {}
    if not exchange:
        raise ConfigError(f"{where}: a co-simulation FMU with clocks "
                          f"({[v.name for v in clocks]}): they are not run here; export it "
                          "as FMI 3 model exchange")
    import zipfile
    from xml.etree import ElementTree

    with zipfile.ZipFile(path) as z:
        root = ElementTree.fromstring(z.read("modelDescription.xml"))
    timing = {int(e.get("valueReference")): e.attrib for e in root.iter("Clock")}

    def decimal(v, key, default=None) -> float:
        try:
            return float(timing.get(v.valueReference, {}).get(key, default))
        except (TypeError, ValueError):
            return math.nan

    out = {}
    for v in clocks:
        fixed = v.intervalVariability == "fixed"
        shift = decimal(v, "shiftDecimal", 0.0)
        interval = None if fixed else decimal(v, "intervalDecimal")
        if v.causality != "input" or v.intervalVariability not in ("constant", "fixed") \
                or not shift >= 0 or not (fixed or (interval > 0 and math.isfinite(interval))):
            raise ConfigError(f"{where}: clock {v.name!r} ({v.causality}, intervalVariability "
                              f"{v.intervalVariability!r}): this master ticks periodic input "
                              "clocks of a constant (intervalDecimal > 0) or fixed interval "
                              "only")
        out[v.valueReference] = (interval, shift)
    return out


def _fixed_intervals(slave, clocks: dict, names: dict, where: str
                     ) -> dict[int, tuple[float, float]]:
    """``clocks`` with each fixed clock's interval, s, as the FMU gives it after its
    initialisation (fmi3GetIntervalDecimal); a ConfigError naming the clock (``names``:
    {value reference: name}) where it gives none > 0."""
    out = dict(clocks)
    for vr, (interval, shift) in clocks.items():
        if interval is None:
            refs = (ctypes.c_uint32 * 1)(vr)
            value, qualifier = (ctypes.c_double * 1)(), (ctypes.c_int * 1)()
            slave.getIntervalDecimal(refs, value, qualifier)
            if qualifier[0] == 0 or not (value[0] > 0 and math.isfinite(value[0])):
                raise ConfigError(f"{where}: clock {names[vr]!r}: its fixed interval is not "
                                  f"known after its initialisation (got {value[0]!r})")
            out[vr] = (float(value[0]), shift)
    return out


def _start(v) -> float:
    """A variable's start value as a number (0 without one; a Boolean's 1 or 0)."""
    x = v.start
    if x is None:
        return 0.0
    if isinstance(x, str) and x.lower() in ("true", "false"):
        return float(x.lower() == "true")
    return float(x)


def _usable(v, causalities, text: bool = False) -> bool:
    """Can the master set or read FMU variable v: a number (or, ``text``, a String or a
    Binary: a parameter's) of one of ``causalities``?"""
    return v.causality in causalities and (v.type in _SETTERS
                                           or (text and v.type in ("String", "Binary")))


def _typed(v, x: float):
    """The machine's (or a block's) value x for input variable v: a Boolean is true from
    0.5 up, an integer type takes x rounded to the nearest integer, a float x."""
    if v.type == "Boolean":
        return bool(x >= 0.5)
    if v.type in _INTEGERS:
        return int(np.rint(x))
    return float(x)


def _exact(v, x, where: str):
    """A parameter's value x for variable v; ConfigError for a non-integral value of an
    integer type, a Boolean that is not 0, 1, true or false, a String that is not text, a
    Binary that is neither bytes nor hex digits, or a number that is text."""
    if v.type == "String":
        if isinstance(x, str):
            return x
        raise ConfigError(f"{where}: expected text (a String), got {x!r}")
    if v.type == "Binary":
        if isinstance(x, bytes | bytearray):
            return bytes(x)
        try:
            return bytes.fromhex(x)
        except (TypeError, ValueError):
            raise ConfigError(f"{where}: expected bytes, or their hex digits as text (a "
                              f"Binary), got {x!r}") from None
    if isinstance(x, str):
        raise ConfigError(f"{where}: expected a number (a {v.type}), got the text {x!r}")
    if v.type == "Boolean":
        if x in (0, 1):  # (True and False among them)
            return bool(x)
        raise ConfigError(f"{where}: expected a Boolean (true, false, 0 or 1), got {x!r}")
    if v.type in _INTEGERS:
        if isinstance(x, int | float) and not isinstance(x, bool) and float(x).is_integer():
            return int(x)
        raise ConfigError(f"{where}: expected an integer (a {v.type}), got {x!r}")
    return float(x)


def cosimulate(sim, blocks: Sequence, t_end: float, macro_step: float,
               progress: bool = False, limits=None, coupling_error: bool = True):
    """Advance the Simulator ``sim`` to ``t_end`` (s) beside the ``blocks`` (:class:`FMU`,
    :class:`SampledPID`) at the communication step ``macro_step`` (s; the last one
    shortened), as the module docstring says; returns ``sim.result(limits=limits)``
    (checked, the coupling's estimated error with it unless ``coupling_error`` is False;
    "partial" with the FMU's message if one fails its step).

    The Simulator must declare every input a block drives; bad names (an FMU's variable, a
    signal, an input), an input driven twice and a controller's period that is not a whole
    multiple of the macro step are a ConfigError naming the block and the name, raised
    before anything runs."""
    if not (np.isfinite(macro_step) and macro_step > 0):
        raise ConfigError(f"co-simulation: macro_step: expected seconds > 0, got {macro_step!r}")
    if not (np.isfinite(t_end) and t_end > sim.t):
        raise ConfigError(f"co-simulation: t_end: expected a time after the Simulator's "
                          f"{sim.t:g} s, got {t_end!r}")
    driven = [target for b in blocks for target in b.targets]
    twice = sorted({x for x in driven if driven.count(x) > 1})
    if twice:
        raise ConfigError(f"co-simulation: {twice} driven by more than one block output")
    twin = sim.copy() if coupling_error else None  # the same start, for the estimate
    failed = _advance(sim, blocks, t_end, macro_step, progress, "co-simulating")
    if failed:
        logger.warning("%s", failed)
        return _partial(sim.result(limits=limits), failed)
    stats = None
    if twin is not None:
        stats = coupling_estimate(sim, twin, blocks, t_end, macro_step, progress)
    return sim.result(limits=limits, stats=stats)


def _advance(sim, blocks: Sequence, t_end: float, macro_step: float, progress: bool,
             what: str) -> str | None:
    """The master loop (module docstring) to t_end; the message of a block that failed its
    step, or None."""
    running = []
    names = block_names(blocks)
    try:
        for name, spec in zip(names, blocks):
            running.append(spec.start(sim, sim.t, name, macro_step))
        _wire(running, names)
        count = int(np.ceil((t_end - sim.t) / macro_step - 1e-9))
        with progress_counter(count, what, progress) as advance:
            for k in range(count):
                t = sim.t
                h = macro_step if k < count - 1 else t_end - t  # the last one to t_end
                # every block's outputs at t before any block steps (Jacobi)
                linked = {f"{BLOCK}{n}.{var}": x for n, b in zip(names, running)
                          for var, x in b.outputs_now().items()}
                values = {}
                for b in running:
                    values.update(b.step(sim, t, h, linked))
                sim.step(h, values)
                advance(k + 1)
    except _StepFailed as exc:
        return str(exc)
    finally:
        for b in running:
            b.close()
    return None


def block_names(blocks: Sequence) -> list[str]:
    """Each block's name (its own, or ``block<k>``); ConfigError for a name given twice."""
    names = [getattr(b, "name", None) or f"block{k}" for k, b in enumerate(blocks)]
    twice = sorted({x for x in names if names.count(x) > 1})
    if twice:
        raise ConfigError(f"co-simulation: block name(s) {twice} given to more than one block")
    return names


def _wire(running: Sequence, names: Sequence[str]) -> None:
    """Check every ``block:<name>.<variable>`` a block reads against the blocks and make
    those outputs readable; ConfigError naming the reader and the signal."""
    wanted: dict[str, list[str]] = {n: [] for n in names}
    for b in running:
        for signal_name in b.reads:
            if not signal_name.startswith(BLOCK):
                continue
            source, dot, var = signal_name[len(BLOCK):].partition(".")
            if source not in wanted or not dot or not var:
                raise ConfigError(f"{b.where}: signal {signal_name!r}: expected "
                                  f"block:<name>.<output> with a block's name ({names})")
            if var not in wanted[source]:
                wanted[source].append(var)
    for name, b in zip(names, running):
        b.exported(wanted[name])


def coupling_estimate(sim, twin, blocks: Sequence, t_end: float, macro_step: float,
                      progress: bool = False) -> dict:
    """The coupling error of ``sim``'s co-simulation at ``macro_step`` (module docstring):
    ``twin`` (a :meth:`Simulator.copy` taken at its start) is advanced beside fresh
    blocks at half the macro step and compared at ``sim``'s communication points.

    Returns {"coupling_ratio" (1: at the tolerance), "coupling_coordinate",
    "coupling_time", "macro_step", "coupling_method"}, or {"coupling_unavailable": why,
    "macro_step"} where the run at half the macro step did not finish.
    """
    out = {"macro_step": float(macro_step),
           "coupling_method": "the blocks again at half the macro step"}
    t0 = twin.t
    try:
        failed = _advance(twin, blocks, t_end, 0.5 * macro_step, progress,
                          "co-simulating at half the macro step (coupling error)")
    except Exception as exc:  # noqa: BLE001 - the estimate is lost, the run stands
        failed = f"{type(exc).__name__}: {exc}"
    if failed:
        return {**out, "coupling_unavailable": f"the run at half the macro step failed: "
                                               f"{failed}"}
    r, fine = sim.history(), twin.history()
    k = np.searchsorted(fine.t, r.t - 1e-9 * macro_step)
    k = np.minimum(k, fine.t.size - 1)
    if not np.allclose(fine.t[k], r.t, rtol=0.0, atol=1e-9 * macro_step):
        return {**out, "coupling_unavailable": "the run at half the macro step has other "
                                               "communication points"}
    after = r.t >= t0 - 1e-9 * macro_step  # before the co-simulation: the same history
    deviation = 2.0 * np.abs(r.q - fine.q[k]) * after[:, None]
    states = 2.0 * np.abs(r.states - fine.states[k]) * after[:, None]
    fig = sim.error_figures(r, deviation, states)
    return {**out, "coupling_ratio": fig["error_ratio"],
            "coupling_coordinate": fig["error_coordinate"],
            "coupling_time": fig["error_time"]}


def _partial(r, message: str):
    from dataclasses import replace

    return replace(r, success=False, status=-1, message=message, verdict="partial")
