/*
 * tests/platforms/host.c -- drives one TireLag binary through a fixed set of cases and prints
 * every value it returns, bit for bit, so that the runs of the same cases on different
 * platforms can be compared (tests/python/test_platforms.py builds it natively, with
 * mingw-w64 for Windows and with zig for Linux aarch64, and runs it under wine and qemu-user).
 *
 *   host [-T] -g GUID LIBRARY
 *
 * The cases, for every tire model (1..4) and friction law (1..3), at the default tire:
 *   cs2  FMI 2.0 Co-Simulation, 2000 steps of 1 ms through five phases of 0.4 s: rolling
 *        with small slip (sticking), large slip (sliding), vx through zero while steering,
 *        Fz through zero and back (lift-off and touchdown), steering at standstill;
 *        then 8 steps of 0.25 s. One line per step: the 9 outputs.
 *   st2  The FMU state taken at step 600 (sliding): restored with fmi2SetFMUstate, and
 *        serialised and deserialised into a fresh instance; each continues to step 2000 and
 *        must give the recorded outputs bit for bit. One line: the serialised bytes (hex).
 *   me2  FMI 2.0 Model Exchange driven by a forward-Euler master (h = 10 us) through the
 *        same five phases, 50 times faster: per step the derivatives, event indicators and
 *        outputs; at every sign change of an indicator an event update (eventInfo's flags and
 *        the states after it).
 *   cs3  FMI 3.0 Co-Simulation, the first 500 steps of cs2.
 * -T adds the cost per step (ns, median of 5 passes of 20000 steps of 1 ms, Brush) for each
 * model: indicative, it depends on the machine and the emulator.
 *
 * The inputs are made with + - * / floor and fabs only, which every platform rounds alike, so
 * any difference between platforms is the binary's own. Doubles are printed as the hex of
 * their bits. Any failed call, or a restored run that differs, ends the host with status 1.
 *
 * Portable C99 (POSIX dlopen, or LoadLibrary on Windows); compile with -ffp-contract=off so
 * that no platform fuses the master's own multiply-adds. FMI headers: those of the fmpy wheel.
 */

#ifndef _WIN32
#define _POSIX_C_SOURCE 200809L /* dlopen, clock_gettime */
#endif
#include <inttypes.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
#else
#include <dlfcn.h>
#include <time.h>
#endif

#include "fmi2Functions.h"
#include "fmi3Functions.h"

#define N_IN 5
#define N_OUT 9
#define N_X 18
#define N_Z 9
#define VR_MODEL 100
#define VR_FRICTION 121
#define VR_FZ0 107
#define CS_STEPS 2000
#define LONG_STEPS 8
#define STATE_AT 600
#define ME_STEPS 4000
#define ME_H 1e-5
#define ME_SPEEDUP 50.0
#define CS3_STEPS 500

static const unsigned int IN_VR[N_IN] = {1, 2, 3, 4, 5};
static const unsigned int OUT_VR[N_OUT] = {11, 12, 13, 14, 15, 16, 17, 18, 19};

/* ------------------------------------------------------------------ plumbing */

static void fail(const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    fputs("host: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    exit(1);
}

static void *library;

static void *need(const char *name) {
#ifdef _WIN32
    void *p = (void *)GetProcAddress((HMODULE)library, name);
#else
    void *p = dlsym(library, name);
#endif
    if (!p) fail("the library does not export %s", name);
    return p;
}

static void open_library(const char *path) {
#ifdef _WIN32
    library = (void *)LoadLibraryA(path);
    if (!library) fail("LoadLibrary(%s) failed: error %lu", path, (unsigned long)GetLastError());
#else
    library = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!library) fail("dlopen(%s): %s", path, dlerror());
#endif
}

static double now_ns(void) {
#ifdef _WIN32
    LARGE_INTEGER f, c;
    QueryPerformanceFrequency(&f);
    QueryPerformanceCounter(&c);
    return 1e9 * (double)c.QuadPart / (double)f.QuadPart;
#else
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return 1e9 * (double)ts.tv_sec + (double)ts.tv_nsec;
#endif
}

static uint64_t bits(double v) {
    uint64_t b;
    memcpy(&b, &v, sizeof b);
    return b;
}

static void print_values(const char *tag, const double *v, size_t n) {
    printf(" %s", tag);
    for (size_t i = 0; i < n; i++) printf(" %016" PRIx64, bits(v[i]));
}

static void check2(fmi2Status s, const char *call) {
    if (s != fmi2OK) fail("%s returned status %d", call, (int)s);
}

static void check3(fmi3Status s, const char *call) {
    if (s != fmi3OK) fail("%s returned status %d", call, (int)s);
}

/* ------------------------------------------------------------------ the inputs */

/* A triangle wave of period p between -1 and 1 (-1 at t = 0). */
static double tri(double t, double p) {
    const double s = t / p - floor(t / p);
    return 4.0 * fabs(s - 0.5) - 1.0;
}

/* vx vy steerRate vsx Fz at scenario time t (s), for a tire of nominal load fz0. */
static void scenario(double t, double fz0, double *u) {
    double vx = 10.0, vy = 0.05 * tri(t, 0.2), steer = 0.02 * tri(t, 0.3), vsx = 0.01 * tri(t, 0.25);
    double fz = fz0 * (1.0 + 0.1 * tri(t, 0.35));
    if (t >= 0.4 && t < 0.8) { /* large slip: sliding */
        vy = 3.0 * tri(t, 0.4);
        vsx = 2.0 * tri(t, 0.3);
    } else if (t >= 0.8 && t < 1.2) { /* vx from 10 through 0 to -2 while steering */
        vx = 10.0 - 30.0 * (t - 0.8);
        vy = 0.2 * tri(t, 0.15);
        steer = 0.5 * tri(t, 0.2);
    } else if (t >= 1.2 && t < 1.6) { /* Fz through zero to -0.2 Fz0 and back */
        const double a = t < 1.4 ? (t - 1.2) / 0.2 : (1.6 - t) / 0.2;
        vx = -2.0;
        vy = 0.5 * tri(t, 0.1);
        fz = fz0 * (1.0 - 1.2 * a);
    } else if (t >= 1.6) { /* steering at standstill */
        vx = 0.0;
        vy = 0.0;
        vsx = 0.0;
        steer = 1.0 * tri(t, 0.1);
    }
    u[0] = vx;
    u[1] = vy;
    u[2] = steer;
    u[3] = vsx;
    u[4] = fz;
}

/* ------------------------------------------------------------------ FMI 2.0 */

static struct {
    fmi2InstantiateTYPE *instantiate;
    fmi2FreeInstanceTYPE *freeInstance;
    fmi2SetupExperimentTYPE *setupExperiment;
    fmi2EnterInitializationModeTYPE *enterInit;
    fmi2ExitInitializationModeTYPE *exitInit;
    fmi2SetIntegerTYPE *setInteger;
    fmi2SetRealTYPE *setReal;
    fmi2GetRealTYPE *getReal;
    fmi2DoStepTYPE *doStep;
    fmi2GetFMUstateTYPE *getState;
    fmi2SetFMUstateTYPE *setState;
    fmi2FreeFMUstateTYPE *freeState;
    fmi2SerializedFMUstateSizeTYPE *serializedSize;
    fmi2SerializeFMUstateTYPE *serialize;
    fmi2DeSerializeFMUstateTYPE *deserialize;
    fmi2SetTimeTYPE *setTime;
    fmi2SetContinuousStatesTYPE *setStates;
    fmi2GetContinuousStatesTYPE *getStates;
    fmi2GetDerivativesTYPE *getDerivatives;
    fmi2GetEventIndicatorsTYPE *getIndicators;
    fmi2EnterEventModeTYPE *enterEventMode;
    fmi2NewDiscreteStatesTYPE *newDiscreteStates;
    fmi2EnterContinuousTimeModeTYPE *enterContinuous;
    fmi2CompletedIntegratorStepTYPE *completedStep;
} f2;

static void load2(void) {
    f2.instantiate = (fmi2InstantiateTYPE *)need("fmi2Instantiate");
    f2.freeInstance = (fmi2FreeInstanceTYPE *)need("fmi2FreeInstance");
    f2.setupExperiment = (fmi2SetupExperimentTYPE *)need("fmi2SetupExperiment");
    f2.enterInit = (fmi2EnterInitializationModeTYPE *)need("fmi2EnterInitializationMode");
    f2.exitInit = (fmi2ExitInitializationModeTYPE *)need("fmi2ExitInitializationMode");
    f2.setInteger = (fmi2SetIntegerTYPE *)need("fmi2SetInteger");
    f2.setReal = (fmi2SetRealTYPE *)need("fmi2SetReal");
    f2.getReal = (fmi2GetRealTYPE *)need("fmi2GetReal");
    f2.doStep = (fmi2DoStepTYPE *)need("fmi2DoStep");
    f2.getState = (fmi2GetFMUstateTYPE *)need("fmi2GetFMUstate");
    f2.setState = (fmi2SetFMUstateTYPE *)need("fmi2SetFMUstate");
    f2.freeState = (fmi2FreeFMUstateTYPE *)need("fmi2FreeFMUstate");
    f2.serializedSize = (fmi2SerializedFMUstateSizeTYPE *)need("fmi2SerializedFMUstateSize");
    f2.serialize = (fmi2SerializeFMUstateTYPE *)need("fmi2SerializeFMUstate");
    f2.deserialize = (fmi2DeSerializeFMUstateTYPE *)need("fmi2DeSerializeFMUstate");
    f2.setTime = (fmi2SetTimeTYPE *)need("fmi2SetTime");
    f2.setStates = (fmi2SetContinuousStatesTYPE *)need("fmi2SetContinuousStates");
    f2.getStates = (fmi2GetContinuousStatesTYPE *)need("fmi2GetContinuousStates");
    f2.getDerivatives = (fmi2GetDerivativesTYPE *)need("fmi2GetDerivatives");
    f2.getIndicators = (fmi2GetEventIndicatorsTYPE *)need("fmi2GetEventIndicators");
    f2.enterEventMode = (fmi2EnterEventModeTYPE *)need("fmi2EnterEventMode");
    f2.newDiscreteStates = (fmi2NewDiscreteStatesTYPE *)need("fmi2NewDiscreteStates");
    f2.enterContinuous = (fmi2EnterContinuousTimeModeTYPE *)need("fmi2EnterContinuousTimeMode");
    f2.completedStep = (fmi2CompletedIntegratorStepTYPE *)need("fmi2CompletedIntegratorStep");
}

static void logger2(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category,
                    fmi2String message, ...) {
    (void)env;
    if (status == fmi2OK) return;
    fprintf(stderr, "host: %s [%s] status %d: %s\n", name ? name : "?", category ? category : "?", (int)status,
            message ? message : "");
}

static const fmi2CallbackFunctions callbacks2 = {logger2, calloc, free, NULL, NULL};
static const char *guid;

static fmi2Component new2(fmi2Type type, int model, int law, double *fz0) {
    fmi2Component c = f2.instantiate("platforms", type, guid, "", &callbacks2, fmi2False, fmi2False);
    if (!c) fail("fmi2Instantiate refused the instance");
    const fmi2ValueReference vr[2] = {VR_MODEL, VR_FRICTION};
    const fmi2Integer value[2] = {model, law};
    check2(f2.setInteger(c, vr, 2, value), "fmi2SetInteger");
    check2(f2.setupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), "fmi2SetupExperiment");
    check2(f2.enterInit(c), "fmi2EnterInitializationMode");
    const fmi2ValueReference fz0_vr = VR_FZ0;
    check2(f2.getReal(c, &fz0_vr, 1, fz0), "fmi2GetReal(Fz0)");
    check2(f2.exitInit(c), "fmi2ExitInitializationMode");
    return c;
}

/* The step k of a Co-Simulation run: h = 1 ms for the first CS_STEPS, then 0.25 s. */
static double cs_time(int k) { return k <= CS_STEPS ? 1e-3 * k : 1e-3 * CS_STEPS + 0.25 * (k - CS_STEPS); }

static void step2(fmi2Component c, int k, double fz0, double *y) {
    const double t = cs_time(k), h = cs_time(k + 1) - t;
    double u[N_IN];
    scenario(t, fz0, u);
    check2(f2.setReal(c, IN_VR, N_IN, u), "fmi2SetReal");
    check2(f2.doStep(c, t, h, fmi2True), "fmi2DoStep");
    check2(f2.getReal(c, OUT_VR, N_OUT, y), "fmi2GetReal");
}

static void same_rows(const double *a, const double *b, int k, const char *how, int model, int law) {
    if (memcmp(a, b, N_OUT * sizeof(double)) != 0)
        fail("model %d law %d: after %s the outputs of step %d differ", model, law, how, k);
}

static void cosimulation2(int model, int law) {
    static double rows[CS_STEPS + LONG_STEPS][N_OUT];
    double fz0, y[N_OUT];
    fmi2Component c = new2(fmi2CoSimulation, model, law, &fz0);
    fmi2FMUstate saved = NULL;
    for (int k = 0; k < CS_STEPS + LONG_STEPS; k++) {
        if (k == STATE_AT) check2(f2.getState(c, &saved), "fmi2GetFMUstate");
        step2(c, k, fz0, rows[k]);
        printf("cs2 %d %d %d", model, law, k);
        print_values("y", rows[k], N_OUT);
        putchar('\n');
    }

    /* Restored in place. */
    check2(f2.setState(c, saved), "fmi2SetFMUstate");
    for (int k = STATE_AT; k < CS_STEPS + LONG_STEPS; k++) {
        step2(c, k, fz0, y);
        same_rows(y, rows[k], k, "fmi2SetFMUstate", model, law);
    }

    /* Serialised, and deserialised into a fresh instance. */
    size_t size = 0;
    check2(f2.serializedSize(c, saved, &size), "fmi2SerializedFMUstateSize");
    fmi2Byte *bytes = malloc(size ? size : 1);
    if (!bytes) fail("out of memory");
    check2(f2.serialize(c, saved, bytes, size), "fmi2SerializeFMUstate");
    double fz0_fresh;
    fmi2Component fresh = new2(fmi2CoSimulation, model, law, &fz0_fresh);
    fmi2FMUstate restored = NULL;
    check2(f2.deserialize(fresh, bytes, size, &restored), "fmi2DeSerializeFMUstate");
    check2(f2.setState(fresh, restored), "fmi2SetFMUstate (deserialised)");
    for (int k = STATE_AT; k < CS_STEPS + LONG_STEPS; k++) {
        step2(fresh, k, fz0, y);
        same_rows(y, rows[k], k, "fmi2DeSerializeFMUstate", model, law);
    }
    printf("st2 %d %d %d s ", model, law, STATE_AT);
    for (size_t i = 0; i < size; i++) printf("%02x", (unsigned)(unsigned char)bytes[i]);
    putchar('\n');
    free(bytes);
    check2(f2.freeState(fresh, &restored), "fmi2FreeFMUstate");
    check2(f2.freeState(c, &saved), "fmi2FreeFMUstate");
    f2.freeInstance(fresh);
    f2.freeInstance(c);
}

static void event_update2(fmi2Component c, int model, int law, int k, double *x) {
    fmi2EventInfo info;
    check2(f2.enterEventMode(c), "fmi2EnterEventMode");
    int rounds = 0;
    do {
        check2(f2.newDiscreteStates(c, &info), "fmi2NewDiscreteStates");
        if (++rounds > 10) fail("model %d law %d: the event update at step %d does not settle", model, law, k);
    } while (info.newDiscreteStatesNeeded);
    check2(f2.enterContinuous(c), "fmi2EnterContinuousTimeMode");
    check2(f2.getStates(c, x, N_X), "fmi2GetContinuousStates");
    printf("ev2 %d %d %d f %d %d %d %d", model, law, k, (int)info.valuesOfContinuousStatesChanged,
           (int)info.nominalsOfContinuousStatesChanged, (int)info.terminateSimulation, (int)info.nextEventTimeDefined);
    print_values("x", x, N_X);
    putchar('\n');
}

static void model_exchange2(int model, int law) {
    double fz0, x[N_X], dx[N_X], z[N_Z], z_before[N_Z], y[N_OUT], u[N_IN];
    fmi2Component c = new2(fmi2ModelExchange, model, law, &fz0);
    event_update2(c, model, law, 0, x);
    for (int k = 0; k < ME_STEPS; k++) {
        const double t = ME_H * k;
        check2(f2.setTime(c, t), "fmi2SetTime");
        scenario(ME_SPEEDUP * t, fz0, u);
        check2(f2.setReal(c, IN_VR, N_IN, u), "fmi2SetReal");
        check2(f2.setStates(c, x, N_X), "fmi2SetContinuousStates");
        check2(f2.getIndicators(c, z, N_Z), "fmi2GetEventIndicators");
        if (k > 0) {
            int crossed = 0;
            for (int i = 0; i < N_Z; i++) crossed |= (z[i] > 0.0) != (z_before[i] > 0.0);
            if (crossed) {
                event_update2(c, model, law, k, x);
                check2(f2.getIndicators(c, z, N_Z), "fmi2GetEventIndicators");
            }
        }
        check2(f2.getDerivatives(c, dx, N_X), "fmi2GetDerivatives");
        check2(f2.getReal(c, OUT_VR, N_OUT, y), "fmi2GetReal");
        printf("me2 %d %d %d", model, law, k);
        print_values("dx", dx, N_X);
        print_values("z", z, N_Z);
        print_values("y", y, N_OUT);
        putchar('\n');
        fmi2Boolean enter = fmi2False, terminate = fmi2False;
        check2(f2.completedStep(c, fmi2True, &enter, &terminate), "fmi2CompletedIntegratorStep");
        for (int i = 0; i < N_X; i++) x[i] += ME_H * dx[i];
        memcpy(z_before, z, sizeof z);
    }
    f2.freeInstance(c);
}

static double cost_per_step(int model) {
    double fz0, y[N_OUT], u[N_IN], pass[5];
    fmi2Component c = new2(fmi2CoSimulation, model, 3, &fz0);
    enum { STEPS = 20000 };
    static double table[STEPS][N_IN];
    for (int k = 0; k < STEPS; k++) scenario(1e-3 * (k % 400), fz0, table[k]); /* the sticking phase */
    long long k = 0;
    for (int p = -1; p < 5; p++) {
        const double start = now_ns();
        for (int i = 0; i < STEPS; i++, k++) {
            memcpy(u, table[i], sizeof u);
            check2(f2.setReal(c, IN_VR, N_IN, u), "fmi2SetReal");
            check2(f2.doStep(c, 1e-3 * (double)k, 1e-3, fmi2True), "fmi2DoStep");
            check2(f2.getReal(c, OUT_VR, N_OUT, y), "fmi2GetReal");
        }
        if (p >= 0) pass[p] = (now_ns() - start) / STEPS;
    }
    f2.freeInstance(c);
    for (int i = 0; i < 5; i++) /* sort the five passes */
        for (int j = i + 1; j < 5; j++)
            if (pass[j] < pass[i]) {
                const double swap = pass[i];
                pass[i] = pass[j];
                pass[j] = swap;
            }
    return pass[2];
}

/* ------------------------------------------------------------------ FMI 3.0 */

static void logger3(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env;
    if (status == fmi3OK) return;
    fprintf(stderr, "host: FMI 3.0 [%s] status %d: %s\n", category ? category : "?", (int)status,
            message ? message : "");
}

static void cosimulation3(int model, int law) {
    fmi3InstantiateCoSimulationTYPE *instantiate =
        (fmi3InstantiateCoSimulationTYPE *)need("fmi3InstantiateCoSimulation");
    fmi3FreeInstanceTYPE *freeInstance = (fmi3FreeInstanceTYPE *)need("fmi3FreeInstance");
    fmi3SetInt64TYPE *setInt64 = (fmi3SetInt64TYPE *)need("fmi3SetInt64");
    fmi3GetFloat64TYPE *getFloat64 = (fmi3GetFloat64TYPE *)need("fmi3GetFloat64");
    fmi3SetFloat64TYPE *setFloat64 = (fmi3SetFloat64TYPE *)need("fmi3SetFloat64");
    fmi3EnterInitializationModeTYPE *enterInit =
        (fmi3EnterInitializationModeTYPE *)need("fmi3EnterInitializationMode");
    fmi3ExitInitializationModeTYPE *exitInit = (fmi3ExitInitializationModeTYPE *)need("fmi3ExitInitializationMode");
    fmi3DoStepTYPE *doStep = (fmi3DoStepTYPE *)need("fmi3DoStep");

    fmi3Instance c = instantiate("platforms", guid, NULL, fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0, NULL,
                                 logger3, NULL);
    if (!c) fail("fmi3InstantiateCoSimulation refused the instance");
    const fmi3ValueReference vr[2] = {VR_MODEL, VR_FRICTION};
    const fmi3Int64 value[2] = {model, law};
    check3(setInt64(c, vr, 2, value, 2), "fmi3SetInt64");
    double fz0, u[N_IN], y[N_OUT];
    check3(enterInit(c, fmi3False, 0.0, 0.0, fmi3False, 0.0), "fmi3EnterInitializationMode");
    const fmi3ValueReference fz0_vr = VR_FZ0;
    check3(getFloat64(c, &fz0_vr, 1, &fz0, 1), "fmi3GetFloat64(Fz0)");
    check3(exitInit(c), "fmi3ExitInitializationMode");
    for (int k = 0; k < CS3_STEPS; k++) {
        const double t = cs_time(k), h = cs_time(k + 1) - t;
        scenario(t, fz0, u);
        check3(setFloat64(c, IN_VR, N_IN, u, N_IN), "fmi3SetFloat64");
        fmi3Boolean event = fmi3False, terminate = fmi3False, early = fmi3False;
        fmi3Float64 reached = 0.0;
        check3(doStep(c, t, h, fmi3True, &event, &terminate, &early, &reached), "fmi3DoStep");
        if (terminate || early || reached != t + h) fail("fmi3DoStep did not complete the step %d", k);
        check3(getFloat64(c, OUT_VR, N_OUT, y, N_OUT), "fmi3GetFloat64");
        printf("cs3 %d %d %d", model, law, k);
        print_values("y", y, N_OUT);
        putchar('\n');
    }
    freeInstance(c);
}

/* ------------------------------------------------------------------ main */

int main(int argc, char **argv) {
    int timing = 0;
    const char *path = NULL;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "-T") == 0) timing = 1;
        else if (strcmp(argv[i], "-g") == 0 && i + 1 < argc) guid = argv[++i];
        else if (argv[i][0] != '-' && !path) path = argv[i];
        else fail("usage: host [-T] -g GUID LIBRARY");
    }
    if (!path || !guid) fail("usage: host [-T] -g GUID LIBRARY");
    open_library(path);
    load2();
    for (int model = 1; model <= 4; model++)
        for (int law = 1; law <= 3; law++) {
            cosimulation2(model, law);
            model_exchange2(model, law);
            cosimulation3(model, law);
        }
    if (timing)
        for (int model = 1; model <= 4; model++) printf("time %d %.1f\n", model, cost_per_step(model));
    fflush(stdout);
    return 0;
}
