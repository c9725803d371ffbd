"""Co-simulation with FMUs: a controller or a circuit block exported by another tool (FMI 2
co-simulation, run through fmpy) advanced at a macro step beside the machine.

The master loop, at each communication point t_k of the macro step H:

1. every FMU's inputs are set from the machine's signals at t_k (:func:`signal`: a
   coordinate ``q:<name>``, its rate ``qd:<name>``, an element's state
   ``state:<element>.<state>``, a marker's position ``marker:<link>.<frame>:x|y|z`` or
   ``time``);
2. every FMU does its step [t_k, t_k + H];
3. its outputs, read after the step, are the machine's inputs over the same interval (a
   :class:`~pipeline.solver.simulator.Simulator` input by name: a force element's history,
   a cylinder's valve command or its controller's reference, a driven coordinate);
4. the machine does its step [t_k, t_k + H].

So the FMUs step first on the machine's state at the start of the interval, and hold their
outputs over it: a sampled controller without a delay (a discrete-time controller's
rhythm). The machine's integration error is estimated and judged as the Simulator's
(:meth:`Simulator.result`); the coupling's own error (the outputs held over H) is the
user's choice of H, and is not estimated here.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pipeline.core.errors import ConfigError
from pipeline.core.progress import progress_counter

logger = logging.getLogger(__name__)

__all__ = ["FMU", "cosimulate", "signal"]


@dataclass(frozen=True)
class FMU:
    """An FMU (FMI 2 co-simulation) in a co-simulation: its file ``path``, its ``inputs``
    ({FMU input variable: the machine's signal}, :func:`signal`), its ``outputs`` ({FMU
    output variable: the Simulator input it drives}) and the start values of its
    ``parameters`` ({variable: value}, set before its initialisation)."""

    path: str | Path
    inputs: Mapping[str, str] = field(default_factory=dict)
    outputs: Mapping[str, str] = field(default_factory=dict)
    parameters: Mapping[str, float] = field(default_factory=dict)


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
        marker, _, axis = target.rpartition(":")
        link, _, frame = marker.partition(".")
        if axis in ("x", "y", "z") and link and frame:
            from pipeline.dynamics.forces.base import marker_pose
            from pipeline.kinematics import evaluate_tree

            tree = evaluate_tree(sim.system.mechanism, sim.q, derivatives=False)
            return float(marker_pose(sim.system, link, frame, tree, sim.q)["xyz".index(axis), 3])
    raise ConfigError(
        f"co-simulation: signal {name!r}: expected time, q:<coordinate>, qd:<coordinate> "
        f"(coordinates: {list(coords)}), state:<element>.<state> (states: "
        f"{list(sim.system.state_names)}) or marker:<link>.<frame>:x|y|z")


class _Slave:
    """One FMU instantiated for a run: its value references and its fmpy slave."""

    def __init__(self, spec: FMU, sim, t0: float, label: str):
        try:
            from fmpy import extract, read_model_description
            from fmpy.fmi2 import FMU2Slave
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
        if md.coSimulation is None:
            raise ConfigError(f"{self.where}: has no co-simulation interface (model "
                              "exchange only); export it for co-simulation")
        if not md.fmiVersion.startswith("2."):
            raise ConfigError(f"{self.where}: FMI {md.fmiVersion}; this master runs FMI 2 "
                              "co-simulation FMUs (FMI 3: not yet)")
        variables = {v.name: v for v in md.modelVariables}

        def refs(names, causalities, what):
            out = []
            for name in names:
                v = variables.get(name)
                if v is None:
                    raise ConfigError(f"{self.where}: {what} {name!r}: no such variable; its "
                                      f"variables: {sorted(variables)}")
                if v.causality not in causalities or v.type != "Real":
                    raise ConfigError(f"{self.where}: {what} {name!r}: expected a Real of "
                                      f"causality {' or '.join(causalities)}, got a "
                                      f"{v.type} {v.causality}")
                out.append(v.valueReference)
            return out

        self.inputs = list(spec.inputs.items())
        self.outputs = list(spec.outputs.items())
        self.in_refs = refs([k for k, _ in self.inputs], ("input",), "input")
        self.out_refs = refs([k for k, _ in self.outputs], ("output",), "output")
        par_refs = refs(list(spec.parameters), ("parameter", "input"), "parameter")
        for _, target in self.outputs:
            if target not in sim.inputs:
                raise ConfigError(f"{self.where}: output drives {target!r}, which is not an "
                                  f"input of the Simulator (its inputs: {sorted(sim.inputs)}; "
                                  "declare it with Simulator(..., inputs=[...]))")
        for _, name in self.inputs:
            signal(sim, name)  # an unknown signal: ConfigError before anything runs
        self.folder = extract(str(path))
        self.slave, self.started = None, False
        try:
            self.slave = FMU2Slave(guid=md.guid, unzipDirectory=self.folder,
                                   modelIdentifier=md.coSimulation.modelIdentifier,
                                   instanceName=label)
            self.slave.instantiate()
            self.slave.setupExperiment(startTime=t0)
            if par_refs:
                self.slave.setReal(par_refs, [float(x) for x in spec.parameters.values()])
            self.slave.enterInitializationMode()
            self._set_inputs(sim)
            self.slave.exitInitializationMode()
            self.started = True
        except ConfigError:
            self.close()
            raise
        except Exception as exc:  # noqa: BLE001 - a binary that will not load or start
            self.close()
            raise ConfigError(f"{self.where}: could not be started ({exc})") from None

    def _set_inputs(self, sim) -> None:
        if self.in_refs:
            self.slave.setReal(self.in_refs, [signal(sim, name) for _, name in self.inputs])

    def step(self, sim, t: float, h: float) -> dict[str, float]:
        """Its step [t, t + h] on the machine's state at t: {Simulator input: value}."""
        self._set_inputs(sim)
        try:
            self.slave.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        except Exception as exc:  # noqa: BLE001 - fmpy raises on any status but OK
            raise _StepFailed(f"{self.where}: its step at t = {t:.6g} s failed ({exc})") \
                from None
        values = self.slave.getReal(self.out_refs) if self.out_refs else []
        return {target: float(x) for (_, target), x in zip(self.outputs, values)}

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


def cosimulate(sim, fmus: Sequence[FMU], t_end: float, macro_step: float,
               progress: bool = False, limits=None):
    """Advance the Simulator ``sim`` to ``t_end`` (s) beside the ``fmus`` at the communication
    step ``macro_step`` (s; the last one shortened), as the module docstring says; returns
    ``sim.result(limits=limits)`` (checked; "partial" with the FMU's message if one fails
    its step).

    The Simulator must declare every input an FMU output drives; bad names (an FMU's
    variable, a signal, an input) are a ConfigError naming the FMU and the name, raised
    before anything runs."""
    if not (np.isfinite(macro_step) and macro_step > 0):
        raise ConfigError(f"co-simulation: macro_step: expected seconds > 0, got {macro_step!r}")
    if not (np.isfinite(t_end) and t_end > sim.t):
        raise ConfigError(f"co-simulation: t_end: expected a time after the Simulator's "
                          f"{sim.t:g} s, got {t_end!r}")
    driven = [target for f in fmus for target in f.outputs.values()]
    twice = sorted({x for x in driven if driven.count(x) > 1})
    if twice:
        raise ConfigError(f"co-simulation: {twice} driven by more than one FMU output")
    slaves = []
    try:
        for k, spec in enumerate(fmus):
            slaves.append(_Slave(spec, sim, sim.t, f"fmu{k}"))
        count = int(np.ceil((t_end - sim.t) / macro_step - 1e-9))
        with progress_counter(count, "co-simulating", progress) as advance:
            for k in range(count):
                t = sim.t
                h = macro_step if k < count - 1 else t_end - t  # the last one to t_end
                values = {}
                for s in slaves:
                    values.update(s.step(sim, t, h))
                sim.step(h, values)
                advance(k + 1)
    except _StepFailed as exc:
        logger.warning("%s", exc)
        return _partial(sim.result(limits=limits), str(exc))
    finally:
        for s in slaves:
            s.close()
    return sim.result(limits=limits)


def _partial(r, message: str):
    from dataclasses import replace

    return replace(r, success=False, status=-1, message=message, verdict="partial")
