/* A sampled PI controller as an FMI 3 model-exchange FMU with a periodic input clock,
 * written for the tests (tests/solver/test_model_exchange.py): at each tick of its clock
 * "tick" (period T, its interval in the model description) it samples its clocked input y
 * and sets its clocked output
 *     u = kp e + x,   e = r - y,   x <- x + T ki e
 * (the law of pipeline.solver.cosim.SampledPID without derivative, feed-forward or
 * limits), held between ticks. T is its parameter "period", which its model description
 * repeats as the clock's constant interval (or, edited to a "fixed" clock, the importer
 * asks for it: fmi3GetIntervalDecimal). Its Binary parameter "law" selects "PI" (default) or "P"
 * (x stays 0). No continuous states, no event indicators.
 *
 * Only the functions a model-exchange importer calls are implemented; the others exist
 * (fmpy binds every FMI 3 function of the library) and return fmi3Error. They are declared
 * without their parameters: on the platforms the tests run on, a C function ignores the
 * arguments it does not declare. */
#include <stdlib.h>
#include <string.h>
#include "fmi3PlatformTypes.h"

typedef int Status;
enum { OK = 0, WARNING = 1, DISCARD = 2, ERROR = 3 };
enum { VR_TIME, VR_TICK, VR_Y, VR_U, VR_KP, VR_KI, VR_R, VR_LAW, VR_PERIOD, N_VR };

typedef struct {
    double v[N_VR];
    double x; /* the integral term */
    int ticking, pi;
} Controller;

const char *fmi3GetVersion(void) { return "3.0"; }
Status fmi3SetDebugLogging(void) { return OK; }

fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token,
                                          fmi3String resources, fmi3Boolean visible,
                                          fmi3Boolean logging, fmi3InstanceEnvironment env,
                                          void *log) {
    Controller *c;
    if (strcmp(token, "{5b0c7a33-9d5e-4a7a-9c55-2f1c0de1a003}")) return NULL;
    c = calloc(1, sizeof(Controller));
    if (!c) return NULL;
    c->v[VR_KP] = 20.0;
    c->v[VR_KI] = 5.0;
    c->v[VR_PERIOD] = 0.01;
    c->pi = 1;
    return c;
}

void fmi3FreeInstance(fmi3Instance c) { free(c); }
Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean tolDefined, fmi3Float64 tol,
                                   fmi3Float64 start, fmi3Boolean stopDefined,
                                   fmi3Float64 stop) {
    ((Controller *)c)->v[VR_TIME] = start;
    return OK;
}
Status fmi3ExitInitializationMode(fmi3Instance c) { return OK; }
Status fmi3EnterEventMode(fmi3Instance c) { return OK; }
Status fmi3Terminate(fmi3Instance c) { return OK; }

Status fmi3GetFloat64(fmi3Instance inst, const fmi3ValueReference vr[], size_t n,
                      fmi3Float64 values[], size_t nValues) {
    Controller *c = inst;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] >= N_VR || vr[i] == VR_TICK || vr[i] == VR_LAW) return ERROR;
        values[i] = c->v[vr[i]];
    }
    return OK;
}

Status fmi3SetFloat64(fmi3Instance inst, const fmi3ValueReference vr[], size_t n,
                      const fmi3Float64 values[], size_t nValues) {
    Controller *c = inst;
    size_t i;
    for (i = 0; i < n; i++) {
        if (vr[i] == VR_Y && !c->ticking) return ERROR; /* clocked: set at its tick only */
        if (vr[i] != VR_Y && vr[i] != VR_KP && vr[i] != VR_KI && vr[i] != VR_R &&
            vr[i] != VR_PERIOD) return ERROR;
        c->v[vr[i]] = values[i];
    }
    return OK;
}

Status fmi3SetBinary(fmi3Instance inst, const fmi3ValueReference vr[], size_t n,
                     const size_t sizes[], const fmi3Binary values[], size_t nValues) {
    Controller *c = inst;
    if (n != 1 || vr[0] != VR_LAW) return ERROR;
    if (sizes[0] == 2 && !memcmp(values[0], "PI", 2)) c->pi = 1;
    else if (sizes[0] == 1 && !memcmp(values[0], "P", 1)) c->pi = 0;
    else return ERROR;
    return OK;
}

Status fmi3SetClock(fmi3Instance inst, const fmi3ValueReference vr[], size_t n,
                    const fmi3Clock values[]) {
    Controller *c = inst;
    if (n != 1 || vr[0] != VR_TICK) return ERROR;
    c->ticking = values[0] ? 1 : 0;
    return OK;
}

Status fmi3GetIntervalDecimal(fmi3Instance inst, const fmi3ValueReference vr[], size_t n,
                              fmi3Float64 intervals[], int qualifiers[]) {
    Controller *c = inst;
    if (n != 1 || vr[0] != VR_TICK) return ERROR;
    intervals[0] = c->v[VR_PERIOD];
    qualifiers[0] = 2; /* fmi3IntervalChanged */
    return OK;
}

Status fmi3UpdateDiscreteStates(fmi3Instance inst, fmi3Boolean *again, fmi3Boolean *terminate,
                                fmi3Boolean *nominals, fmi3Boolean *values,
                                fmi3Boolean *timed, fmi3Float64 *next) {
    Controller *c = inst;
    if (c->ticking) { /* the sample: its output, then the integral */
        double e = c->v[VR_R] - c->v[VR_Y];
        c->v[VR_U] = c->v[VR_KP] * e + c->x;
        if (c->pi) c->x += c->v[VR_PERIOD] * c->v[VR_KI] * e;
        c->ticking = 0; /* a clock is active for one event only */
    }
    *again = *terminate = *nominals = *values = *timed = fmi3False;
    *next = 0.0;
    return OK;
}

Status fmi3EnterContinuousTimeMode(fmi3Instance c) { return OK; }
Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean noSet, fmi3Boolean *event,
                                   fmi3Boolean *terminate) {
    *event = *terminate = fmi3False;
    return OK;
}
Status fmi3SetTime(fmi3Instance c, fmi3Float64 t) { ((Controller *)c)->v[VR_TIME] = t; return OK; }
Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 x[], size_t n) { return n ? ERROR : OK; }
Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) { return n ? ERROR : OK; }
Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 d[], size_t n) { return n ? ERROR : OK; }
Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) { return n ? ERROR : OK; }
Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 z[], size_t n) { return n ? ERROR : OK; }
Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) { *n = 0; return OK; }
Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) { *n = 0; return OK; }

/* the rest of the FMI 3 interface: not this FMU's */
#define STUB(name) Status name(void) { return ERROR; }
STUB(fmi3ActivateModelPartition) STUB(fmi3DeserializeFMUState) STUB(fmi3DoStep)
STUB(fmi3EnterConfigurationMode) STUB(fmi3EnterStepMode) STUB(fmi3EvaluateDiscreteStates)
STUB(fmi3ExitConfigurationMode) STUB(fmi3FreeFMUState) STUB(fmi3GetAdjointDerivative)
STUB(fmi3GetBinary) STUB(fmi3GetBoolean) STUB(fmi3GetClock)
STUB(fmi3GetDirectionalDerivative) STUB(fmi3GetFMUState) STUB(fmi3GetFloat32)
STUB(fmi3GetInt16) STUB(fmi3GetInt32) STUB(fmi3GetInt64) STUB(fmi3GetInt8)
STUB(fmi3GetIntervalFraction)
STUB(fmi3GetNumberOfVariableDependencies) STUB(fmi3GetOutputDerivatives)
STUB(fmi3GetShiftDecimal) STUB(fmi3GetShiftFraction) STUB(fmi3GetString) STUB(fmi3GetUInt16)
STUB(fmi3GetUInt32) STUB(fmi3GetUInt64) STUB(fmi3GetUInt8) STUB(fmi3GetVariableDependencies)
STUB(fmi3InstantiateCoSimulation) STUB(fmi3InstantiateScheduledExecution) STUB(fmi3Reset)
STUB(fmi3SerializeFMUState) STUB(fmi3SerializedFMUStateSize) STUB(fmi3SetBoolean)
STUB(fmi3SetFMUState) STUB(fmi3SetFloat32) STUB(fmi3SetInt16) STUB(fmi3SetInt32)
STUB(fmi3SetInt64) STUB(fmi3SetInt8) STUB(fmi3SetIntervalDecimal)
STUB(fmi3SetIntervalFraction) STUB(fmi3SetShiftDecimal) STUB(fmi3SetShiftFraction)
STUB(fmi3SetString) STUB(fmi3SetUInt16) STUB(fmi3SetUInt32) STUB(fmi3SetUInt64)
STUB(fmi3SetUInt8)
