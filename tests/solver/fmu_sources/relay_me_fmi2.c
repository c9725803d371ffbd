/* A relay oscillator as an FMI 2 model-exchange FMU, written for the tests
 * (tests/solver/test_model_exchange.py): its state x follows
 *     x' = (u + b on - x) / tau,
 * it switches off where x rises to hi and on where x falls to lo (a state event: the
 * indicator x - hi while on, x - lo while off), its output command is +amp on, -amp off;
 * at t_off (a time event) it is switched off for good (command 0). The same model as the
 * FMI 3 one the tests build with pythonfmu3. */
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"

enum { VR_X, VR_DERX, VR_U, VR_COMMAND, VR_TAU, VR_B, VR_LO, VR_HI, VR_AMP, VR_TRESET, N_VR };

typedef struct {
    double v[N_VR];
    double time;
    int on, pending, reset;
} Relay;

static double command(const Relay *r) { return r->on ? r->v[VR_AMP] : -r->v[VR_AMP]; }

static void refresh(Relay *r) {
    double drive = r->on ? r->v[VR_B] : 0.0;
    r->v[VR_DERX] = (r->v[VR_U] + drive - r->v[VR_X]) / r->v[VR_TAU];
    r->v[VR_COMMAND] = command(r);
}

static void update(Relay *r) {
    r->reset = 0;
    if (r->pending && r->time >= r->v[VR_TRESET]) {
        r->pending = 0;
        r->reset = 1;
        r->v[VR_X] = r->v[VR_LO];
        r->on = 1;
    } else if (r->on && r->v[VR_X] >= r->v[VR_HI]) r->on = 0;
    else if (!r->on && r->v[VR_X] <= r->v[VR_LO]) r->on = 1;
    refresh(r);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) {
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid,
                              fmi2String location, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean logging) {
    Relay *r;
    if (type != fmi2ModelExchange || strcmp(guid, "{8c4e810f-3df3-4a00-8276-176fa3c9f000}"))
        return NULL;
    r = calloc(1, sizeof(Relay));
    if (!r) return NULL;
    r->v[VR_X] = 0.2;
    r->v[VR_TAU] = 0.01;
    r->v[VR_B] = 0.2;
    r->v[VR_LO] = 0.25;
    r->v[VR_HI] = 0.3;
    r->v[VR_AMP] = 0.2;
    r->v[VR_TRESET] = 1e9;
    r->on = 1;
    r->pending = 1;
    refresh(r);
    return r;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDefined, fmi2Real tol,
                               fmi2Real start, fmi2Boolean stopDefined, fmi2Real stop) {
    ((Relay *)c)->time = start;
    return fmi2OK;
}
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { update((Relay *)c); return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { return fmi2Error; }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Relay *r = c;
    size_t i;
    refresh(r);
    for (i = 0; i < n; i++) {
        if (vr[i] >= N_VR) return fmi2Error;
        value[i] = r->v[vr[i]];
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Relay *r = c;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] >= N_VR || vr[i] == VR_DERX || vr[i] == VR_COMMAND) return fmi2Error;
        r->v[vr[i]] = value[i];
    }
    refresh(r);
    return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) { return fmi2Error; }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { return fmi2Error; }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { return fmi2Error; }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) { return fmi2Error; }
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) { return fmi2Error; }
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s) { return fmi2Error; }
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
                                        const fmi2ValueReference z[], size_t nz,
                                        const fmi2Real du[], fmi2Real dz[]) { return fmi2Error; }

fmi2Status fmi2EnterEventMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    Relay *r = c;
    update(r);
    info->newDiscreteStatesNeeded = fmi2False;
    info->terminateSimulation = fmi2False;
    info->nominalsOfContinuousStatesChanged = fmi2False;
    info->valuesOfContinuousStatesChanged = r->reset ? fmi2True : fmi2False;
    info->nextEventTimeDefined = r->pending ? fmi2True : fmi2False;
    info->nextEventTime = r->v[VR_TRESET];
    return fmi2OK;
}
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSet, fmi2Boolean *event,
                                       fmi2Boolean *terminate) {
    *event = fmi2False;
    *terminate = fmi2False;
    return fmi2OK;
}
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time) { ((Relay *)c)->time = time; return fmi2OK; }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx) {
    if (nx != 1) return fmi2Error;
    ((Relay *)c)->v[VR_X] = x[0];
    return fmi2OK;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t nx) {
    if (nx != 1) return fmi2Error;
    refresh((Relay *)c);
    dx[0] = ((Relay *)c)->v[VR_DERX];
    return fmi2OK;
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t nz) {
    Relay *r = c;
    if (nz != 1) return fmi2Error;
    z[0] = r->v[VR_X] - (r->on ? r->v[VR_HI] : r->v[VR_LO]);
    return fmi2OK;
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    if (nx != 1) return fmi2Error;
    x[0] = ((Relay *)c)->v[VR_X];
    return fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t nx) {
    if (nx != 1) return fmi2Error;
    x[0] = 1.0;
    return fmi2OK;
}

/* co-simulation: not this FMU's interface */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real value[]) { return fmi2Error; }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                        const fmi2Integer order[], fmi2Real value[]) { return fmi2Error; }
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSet) { return fmi2Error; }
fmi2Status fmi2CancelStep(fmi2Component c) { return fmi2Error; }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v) { return fmi2Error; }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v) { return fmi2Error; }
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v) { return fmi2Error; }
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v) { return fmi2Error; }
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v) { return fmi2Error; }
