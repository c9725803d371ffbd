"""Model-exchange FMUs with events beside the machine (issue 27, item 5;
pipeline.solver.model_exchange).

The FMU: a relay oscillator, written here twice, as an FMI 2 model-exchange FMU in C
(``fmu_sources/relay_me_fmi2.c``, compiled by the system's C compiler against fmpy's FMI 2
headers) and as an FMI 3 one in Python (pythonfmu3). Its state x follows
x' = (u + b on - x) / tau with u the lift's stroke; it switches off where x rises to hi and
on where x falls to lo (state events), its output, the lift's valve command, is +amp on and
-amp off, and at t_reset (a time event) it is reset (x = lo, switched on). With tau = 10 ms
and a 5 ms macro step it switches about twice a macro step, so where the events fall
inside a step sets x at its end.

The reference, built here: the same loop around a Simulator by hand, the relay advanced
over each macro step in closed form with its input held (x is exponential between
switches; each switch time is tau ln((x - x_target) / (threshold - x_target))).

FMI 3 clocks: a sampled PI controller written in C as an FMI 3 model-exchange FMU with a
10 ms periodic input clock (``fmu_sources/sampled_pi_me_fmi3.c``), against the built-in
SampledPID of the same law and period (pipeline.solver.cosim, written independently).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_hydraulic_cylinder import S0, _lift

from pipeline.solver.cosim import FMU, cosimulate
from pipeline.solver.simulator import Simulator

SOURCES = Path(__file__).resolve().parent / "fmu_sources"
TAU, B, LO, HI, AMP = 0.01, 0.2, 0.25, 0.3, 0.2
H, T_END = 5e-3, 0.3

RELAY3 = '''
from pythonfmu3 import (Fmi3Causality, Fmi3Initial, Fmi3SlaveBase, Fmi3UpdateDiscreteStatesResult,
                        Fmi3Variability, Float64, ModelExchange)


class Relay(Fmi3SlaveBase, ModelExchange):
    """The relay oscillator of tests/solver/test_model_exchange.py (FMI 3 model exchange)."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.author = "tests"
        self.description = "relay oscillator (model exchange)"
        self.time = 0.0
        self.x, self.derx, self.u, self.command = 0.2, 0.0, 0.0, 0.2
        self.tau, self.b, self.lo, self.hi, self.amp = 0.01, 0.2, 0.25, 0.3, 0.2
        self.t_reset, self.on, self.pending, self.g = 1e9, True, True, 0.0
        self.register_variable(Float64("time", causality=Fmi3Causality.independent,
                                       variability=Fmi3Variability.continuous))
        self.register_variable(Float64("x", causality=Fmi3Causality.output, start=0.2,
                                       variability=Fmi3Variability.continuous,
                                       initial=Fmi3Initial.exact))
        self.register_variable(Float64("derx", causality=Fmi3Causality.local,
                                       variability=Fmi3Variability.continuous, derivative=1))
        self.register_variable(Float64("u", causality=Fmi3Causality.input,
                                       variability=Fmi3Variability.continuous))
        self.register_variable(Float64("command", causality=Fmi3Causality.output,
                                       variability=Fmi3Variability.discrete))
        for name in ("tau", "b", "lo", "hi", "amp", "t_reset"):
            self.register_variable(Float64(name, causality=Fmi3Causality.parameter,
                                           variability=Fmi3Variability.fixed))
        self.register_variable(Float64("g", causality=Fmi3Causality.local,
                                       variability=Fmi3Variability.continuous),
                               has_event_indicator=True)

    def get_continuous_state_derivatives(self):
        self.derx = (self.u + (self.b if self.on else 0.0) - self.x) / self.tau
        return [self.derx]

    def get_event_indicators(self):
        self.g = self.x - (self.hi if self.on else self.lo)
        return [self.g]

    def update_discrete_states(self):
        reset = self.pending and self.time >= self.t_reset
        if reset:
            self.pending, self.x, self.on = False, self.lo, True
        elif self.on and self.x >= self.hi:
            self.on = False
        elif not self.on and self.x <= self.lo:
            self.on = True
        self.command = self.amp if self.on else -self.amp
        return Fmi3UpdateDiscreteStatesResult(valuesOfContinuousStatesChanged=reset,
                                              nextEventTimeDefined=self.pending,
                                              nextEventTime=self.t_reset)
'''


@pytest.fixture(scope="module")
def relay_fmi2(tmp_path_factory):
    """The C relay compiled into an FMI 2 model-exchange FMU."""
    return _compiled_fmu(tmp_path_factory.mktemp("relay2"), "relay_me_fmi2", "relay", False)


def _compiled_fmu(folder: Path, source: str, identifier: str, fmi3: bool) -> Path:
    """``fmu_sources/<source>.c`` compiled with its model description into an FMU (its
    binary under binaries/<this platform>/<identifier>); skipped without a C compiler."""
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler to build the test FMU")
    import fmpy

    if fmpy.sharedLibraryExtension != ".so":
        pytest.skip("the test FMUs are built with a Unix C compiler")
    platform = fmpy.platform_tuple if fmi3 else fmpy.platform
    binary = folder / "binaries" / platform / f"{identifier}.so"
    binary.parent.mkdir(parents=True)
    subprocess.run([cc, "-shared", "-fPIC", "-O2", "-I",
                    str(Path(fmpy.__file__).parent / "c-code"),
                    str(SOURCES / f"{source}.c"), "-o", str(binary)], check=True)
    fmu = folder / f"{source}.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        z.write(SOURCES / f"{source}.xml", "modelDescription.xml")
        z.write(binary, f"binaries/{platform}/{identifier}.so")
    return fmu


@pytest.fixture(scope="module")
def relay_fmi3(tmp_path_factory):
    pytest.importorskip("pythonfmu3")
    from pythonfmu3 import FmuBuilder

    folder = tmp_path_factory.mktemp("relay3")
    script = folder / "relay3.py"
    script.write_text(RELAY3)
    return Path(FmuBuilder.build_FMU(script, dest=folder, needsExecutionTool="false"))


def _sim():
    system, _ = _lift(0.0, viscous_friction=1e4)
    return Simulator(system, np.array([S0]), step=5e-4, inputs={"lift": 0.0}, rtol=1e-2,
                     atol=1e-7)


def _relay(x, on, pending, u, t, h, t_reset):
    """The relay over [t, t + h] with u held, in closed form: (x, on, pending, switches)."""
    switches, end = 0, t + h
    while True:
        target = u + (B if on else 0.0)
        limit = min(end, t_reset) if pending else end
        thr = HI if on else LO
        if (target - thr) * (thr - x) > 0:  # heading for the threshold
            tc = t + TAU * np.log((x - target) / (thr - target))
            if tc <= limit:
                x, t, on, switches = thr, tc, not on, switches + 1
                continue
        x = target + (x - target) * np.exp(-(limit - t) / TAU)
        t = limit
        if pending and t >= t_reset:  # the reset: x = lo, on
            x, on, pending = LO, True, False
            continue
        if t >= end:
            return x, on, pending, switches


def _by_hand(t_reset=1e9):
    """The co-simulation by hand (module docstring): the Simulator's result and the relay's
    switches."""
    sim, x, on, pending, switches = _sim(), 0.2, True, True, 0
    while sim.t < T_END - 1e-12:
        x, on, pending, n = _relay(x, on, pending, sim.q[0], sim.t, H, t_reset)
        switches += n
        sim.step(H, {"lift": AMP if on else -AMP})
    return sim.result(), switches


def _run(fmu, **parameters):
    block = FMU(fmu, inputs={"u": "q:slide.d"}, outputs={"command": "lift"},
                parameters=parameters)
    return cosimulate(_sim(), [block], T_END, H, coupling_error=False)


@pytest.mark.parametrize("which", ["fmi2", "fmi3"])
def test_a_relay_fmus_state_events_are_located_inside_the_macro_steps(which, request):
    """Beside the lift, the relay switches inside the macro steps, and its outputs at the
    steps' ends are the closed form's: the stroke within 1e-9 m of the loop by hand (the
    same commands, so the same stroke to the last bit here), over 50 switches; switches
    taken at the steps' ends only would give another run. FMI 2 (C) and FMI 3
    (Python)."""
    fmu = request.getfixturevalue(f"relay_{which}")
    ref, switches = _by_hand()
    assert switches > 40  # about two a macro step: their times inside it matter
    r = _run(fmu)
    err = np.abs(r.q - ref.q).max()
    print(f"{which}: {switches} switches, stroke against the closed form {err:.2e} m")
    assert err < 1e-9 and np.abs(r.q - ref.q[0]).max() > 1e-3
    # the switches seen only at the macro steps' ends (x at its end, events deferred
    # there) give another run: the in-step location is what the test sees
    assert np.abs(ref.q - _by_hand_at_ends().q).max() > 1e-6


def _by_hand_at_ends():
    """The same loop with the relay's switches taken at the macro steps' ends only."""
    sim, x, on = _sim(), 0.2, True
    while sim.t < T_END - 1e-12:
        u = sim.q[0]
        target = u + (B if on else 0.0)
        x = target + (x - target) * np.exp(-H / TAU)
        if on and x >= HI:
            on = False
        elif not on and x <= LO:
            on = True
        sim.step(H, {"lift": AMP if on else -AMP})
    return sim.result()


@pytest.mark.parametrize("which", ["fmi2", "fmi3"])
def test_a_time_event_inside_a_macro_step_is_taken_at_its_time(which, request):
    """At t_reset = 0.1525 s (inside a macro step) the relay is reset (x = lo, switched
    on; the FMU says its state changed): the stroke within 1e-9 m of the loop by hand,
    which differs from a reset at the step's end by far more."""
    fmu = request.getfixturevalue(f"relay_{which}")
    ref, _ = _by_hand(t_reset=0.1525)
    r = _run(fmu, t_reset=0.1525)
    err = np.abs(r.q - ref.q).max()
    print(f"{which}: reset at 0.1525 s, stroke against the closed form {err:.2e} m")
    assert err < 1e-9
    assert np.abs(ref.q - _by_hand(t_reset=0.155)[0].q).max() > 1e-5
    assert np.abs(ref.q - _by_hand()[0].q).max() > 1e-5


def _opened(fmu, folder, t_reset):
    """The relay FMU instantiated through fmpy and initialised (u = 0.2, its reset at
    ``t_reset``): (its fmpy model, its ModelExchange, {name: value reference}, its setter
    and getter of floats)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Model
    from fmpy.fmi3 import FMU3Model

    from pipeline.solver.model_exchange import ModelExchange

    md = read_model_description(str(fmu))
    fmi3 = md.fmiVersion.startswith("3.")
    model = (FMU3Model if fmi3 else FMU2Model)(
        guid=md.guid, unzipDirectory=extract(str(fmu), str(folder)),
        modelIdentifier=md.modelExchange.modelIdentifier, instanceName="relay")
    model.instantiate()
    vr = {v.name: v.valueReference for v in md.modelVariables}
    if fmi3:
        model.enterInitializationMode(startTime=0.0)
    else:
        model.setupExperiment(startTime=0.0)
        model.enterInitializationMode()
    (model.setFloat64 if fmi3 else model.setReal)([vr["u"], vr["t_reset"]], [0.2, t_reset])
    model.exitInitializationMode()
    me = ModelExchange(model, fmi3, md.numberOfContinuousStates, md.numberOfEventIndicators,
                       "relay", 0.0)
    return model, me, vr, (model.setFloat64 if fmi3 else model.setReal), \
        (model.getFloat64 if fmi3 else model.getReal)


@pytest.mark.parametrize("which", ["fmi2", "fmi3"])
def test_the_relays_state_is_its_closed_form_after_each_macro_step(which, request,
                                                                  tmp_path):
    """The FMU alone, its input stepped at each 5 ms macro step: its state x and output
    after each step against the closed form over 50 switches and a reset (its state
    changed by the FMU) at 0.1525 s. x within 1e-7: an event misplaced by dt moves x by
    20 dt (the jump in x'); measured 3.3e-8, LSODA's error at its rtol 1e-9 over 51
    restarts (3.8e-9 at 1e-10, 3.4e-10 at 1e-11)."""
    fmu = request.getfixturevalue(f"relay_{which}")
    model, me, vr, put, get = _opened(fmu, tmp_path, 0.1525)
    x, on, pending, switches, worst = 0.2, True, True, 0, 0.0
    for k in range(60):
        t, u = k * H, 0.2 + 0.03 * np.sin(0.7 * k)
        put([vr["u"]], [u])
        me.inputs_set(t)
        me.advance(t, H)
        x, on, pending, n = _relay(x, on, pending, u, t, H, 0.1525)
        switches += n
        worst = max(worst, abs(me.x[0] - x))
        assert get([vr["command"]])[0] == (AMP if on else -AMP), k
    print(f"{which}: {switches} switches, {me.events} events, x within {worst:.2e}")
    assert switches + 1 == me.events and switches > 40 and worst < 1e-7  # (+ the reset)
    model.terminate()
    model.freeInstance()


def test_fmi2_and_fmi3_give_the_same_run(relay_fmi2, relay_fmi3):
    a, b = _run(relay_fmi2), _run(relay_fmi3)
    assert np.abs(a.q - b.q).max() < 1e-12


def test_a_chattering_fmu_fails_its_step_in_one_line(relay_fmi2):
    """lo = hi: switched off at the threshold, x falls back below it at once and switches
    on again (a sliding mode the FMU does not handle): 1000 events in one macro step are
    refused, the run partial with the line that says so."""
    r = _run(relay_fmi2, lo=0.3, hi=0.3)
    assert r.verdict == "partial"
    assert "1000 events between t = " in r.message and "chattering" in r.message


# ------------------------------------------------------------------ FMI 3 clocks
@pytest.fixture(scope="module")
def sampled_pi(tmp_path_factory):
    """The C sampled PI controller with its 10 ms clock (FMI 3 model exchange)."""
    return _compiled_fmu(tmp_path_factory.mktemp("pi3"), "sampled_pi_me_fmi3", "sampled_pi",
                         True)


@pytest.mark.parametrize("law, ki", [(None, 10.0), (b"P", 0.0), ("50", 0.0)])
def test_a_clocked_fmu_samples_at_its_own_ticks(sampled_pi, law, ki):
    """A sampled PI controller FMU whose clock ticks every 10 ms, run at a 5 ms macro
    step: it samples the stroke at its ticks only and holds its output between them, as
    the built-in SampledPID of the same law and period does (to 1e-12). Its Binary
    parameter ``law`` (bytes, or hex digits: 0x50 is "P") takes the integral out."""
    from pipeline.solver.cosim import SampledPID

    goal, kp = S0 + 0.04, 25.0
    parameters = {"kp": kp, "ki": 10.0, "r": goal, **({"law": law} if law else {})}
    fmu = FMU(sampled_pi, inputs={"y": "q:slide.d"}, outputs={"u": "lift"},
              parameters=parameters)
    r = cosimulate(_sim(), [fmu], T_END, H, coupling_error=False)
    ref = cosimulate(_sim(), [SampledPID("q:slide.d", "lift", goal, kp, ki, period=0.01)],
                     T_END, H, coupling_error=False)
    assert np.abs(r.q - ref.q).max() < 1e-12 and r.q[-1, 0] - S0 > 0.01
    every = cosimulate(_sim(), [SampledPID("q:slide.d", "lift", goal, kp, ki, period=H)],
                       T_END, H, coupling_error=False)
    assert np.abs(every.q - r.q).max() > 1e-5  # its own rhythm, not the macro step's


#: the test FMU's clock as its model description declares it
CONSTANT = 'intervalVariability="constant" intervalDecimal="0.01"'


def _edited(fmu: Path, folder: Path, old: str, new: str) -> Path:
    """A copy of ``fmu`` whose modelDescription.xml has ``old`` replaced by ``new``."""
    out = folder / f"edited{len(list(folder.iterdir()))}.fmu"
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(out, "w") as dst:
        for item in src.infolist():
            data = src.read(item)
            if item.filename == "modelDescription.xml":
                assert old in data.decode()
                data = data.decode().replace(old, new).encode()
            dst.writestr(item, data)
    return out


def test_a_fixed_clocks_interval_is_the_one_the_fmu_gives(sampled_pi, tmp_path):
    """The same FMU with its clock declared "fixed" (no interval in its model description)
    and its period parameter at 20 ms: the master asks the FMU for the interval after its
    initialisation and ticks at it, the built-in SampledPID at 20 ms to the bit."""
    from pipeline.solver.cosim import SampledPID

    fixed = _edited(sampled_pi, tmp_path, CONSTANT, 'intervalVariability="fixed"')
    goal, kp = S0 + 0.04, 25.0
    r = cosimulate(_sim(), [FMU(fixed, inputs={"y": "q:slide.d"}, outputs={"u": "lift"},
                                parameters={"kp": kp, "ki": 10.0, "r": goal,
                                            "period": 0.02})], T_END, H, coupling_error=False)
    ref = cosimulate(_sim(), [SampledPID("q:slide.d", "lift", goal, kp, 10.0, period=0.02)],
                     T_END, H, coupling_error=False)
    assert np.abs(r.q - ref.q).max() < 1e-12
    ten = cosimulate(_sim(), [SampledPID("q:slide.d", "lift", goal, kp, 10.0, period=0.01)],
                     T_END, H, coupling_error=False)
    assert np.abs(ten.q - r.q).max() > 1e-5


def test_what_clocks_are_not_run_is_said_in_one_line(sampled_pi, tmp_path):
    """A clock that is not a periodic input clock of a constant or fixed interval, a
    co-simulation FMU with clocks, and a Binary parameter that is neither bytes nor hex:
    one line each, before anything runs."""
    from pipeline.core.errors import ConfigError

    io = {"inputs": {"y": "q:slide.d"}, "outputs": {"u": "lift"}}
    triggered = _edited(sampled_pi, tmp_path, CONSTANT, 'intervalVariability="triggered"')
    with pytest.raises(ConfigError, match=r"clock 'tick' \(input, intervalVariability "
                                          r"'triggered'\): this master ticks periodic input "
                                          r"clocks of a constant \(intervalDecimal > 0\) or "
                                          r"fixed interval only"):
        cosimulate(_sim(), [FMU(triggered, **io)], 0.1, H)
    cs = _edited(sampled_pi, tmp_path, '<ModelExchange modelIdentifier="sampled_pi"/>',
                 '<CoSimulation modelIdentifier="sampled_pi"/>')
    with pytest.raises(ConfigError, match=r"a co-simulation FMU with clocks \(\['tick'\]\): "
                                          r"they are not run here"):
        cosimulate(_sim(), [FMU(cs, **io)], 0.1, H)
    with pytest.raises(ConfigError, match=r"parameter 'law': expected bytes, or their hex "
                                          r"digits as text \(a Binary\), got 'P'"):
        cosimulate(_sim(), [FMU(sampled_pi, **io, parameters={"law": "P"})], 0.1, H)
