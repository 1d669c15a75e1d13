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
 *   me3  FMI 3.0 Model Exchange, as me2 (ev3: its event updates).
 *   sl2  A stiff tire at a light load (Calpha = Ckappa = 1e7 N/rad, sigmaY = sigmaX = 0.05 m,
 *        sigmaTread = 0.01 m, the load about 100 N): 600 steps of 1 ms through the sliding,
 *        vx through zero and lift-off phases of cs2, twice as fast.
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
#define STIFF_STEPS 600
#define STIFF_LOAD 100.0

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

/* Calpha, Ckappa, sigmaY, sigmaX, sigmaTread of the stiff tire. */
static const fmi2ValueReference STIFF_VR[5] = {101, 102, 103, 104, 119};
static const fmi2Real STIFF_VALUE[5] = {1e7, 1e7, 0.05, 0.05, 0.01};

static fmi2Component new2_with(fmi2Type type, int model, int law, int stiff, double *fz0) {
    fmi2Component c = f2.instantiate("platforms", type, guid, "", &callbacks2, fmi2False, fmi2False);
    if (!c) fail("fmi2Instantiate refused the instance");
    const fmi2ValueReference vr[2] = {VR_MODEL, VR_FRICTION};
    const fmi2Integer value[2] = {model, law};
    check2(f2.setInteger(c, vr, 2, value), "fmi2SetInteger");
    if (stiff) check2(f2.setReal(c, STIFF_VR, 5, STIFF_VALUE), "fmi2SetReal (stiff tire)");
    check2(f2.setupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0), "fmi2SetupExperiment");
    check2(f2.enterInit(c), "fmi2EnterInitializationMode");
    const fmi2ValueReference fz0_vr = VR_FZ0;
    check2(f2.getReal(c, &fz0_vr, 1, fz0), "fmi2GetReal(Fz0)");
    check2(f2.exitInit(c), "fmi2ExitInitializationMode");
    return c;
}

static fmi2Component new2(fmi2Type type, int model, int law, double *fz0) {
    return new2_with(type, model, law, 0, fz0);
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

static void stiff_light2(int model, int law) {
    double fz0, u[N_IN], y[N_OUT];
    fmi2Component c = new2_with(fmi2CoSimulation, model, law, 1, &fz0);
    for (int k = 0; k < STIFF_STEPS; k++) {
        const double t = 1e-3 * k;
        scenario(0.4 + 2.0 * t, STIFF_LOAD, u);
        check2(f2.setReal(c, IN_VR, N_IN, u), "fmi2SetReal");
        check2(f2.doStep(c, t, 1e-3, fmi2True), "fmi2DoStep");
        check2(f2.getReal(c, OUT_VR, N_OUT, y), "fmi2GetReal");
        printf("sl2 %d %d %d", model, law, k);
        print_values("y", y, N_OUT);
        putchar('\n');
    }
    f2.freeInstance(c);
}

/* ------------------------------------------------------------------ Model Exchange, either version */

/* One Model Exchange instance behind the calls the forward-Euler master makes. */
typedef struct {
    const char *tag; /* "2" or "3": the rows are me2/ev2 or me3/ev3 */
    void (*set_time)(double t);
    void (*set_inputs)(const double *u);
    void (*set_states)(const double *x);
    void (*get_indicators)(double *z);
    void (*get_derivatives)(double *dx);
    void (*get_outputs)(double *y);
    /* Event mode, the update (repeated until settled), back to continuous time; fills
     * flags (values changed, nominals changed, terminate, next event time defined). */
    void (*event_update)(int *flags);
    void (*get_states)(double *x);
    void (*completed_step)(void);
} MeDriver;

static void event_update(const MeDriver *me, int model, int law, int k, double *x) {
    int flags[4];
    me->event_update(flags);
    me->get_states(x);
    printf("ev%s %d %d %d f %d %d %d %d", me->tag, model, law, k, flags[0], flags[1], flags[2], flags[3]);
    print_values("x", x, N_X);
    putchar('\n');
}

static void model_exchange(const MeDriver *me, int model, int law, double fz0) {
    double x[N_X], dx[N_X], z[N_Z], z_before[N_Z], y[N_OUT], u[N_IN];
    event_update(me, model, law, 0, x);
    for (int k = 0; k < ME_STEPS; k++) {
        const double t = ME_H * k;
        me->set_time(t);
        scenario(ME_SPEEDUP * t, fz0, u);
        me->set_inputs(u);
        me->set_states(x);
        me->get_indicators(z);
        if (k > 0) {
            int crossed = 0;
            for (int i = 0; i < N_Z; i++) crossed |= (z[i] > 0.0) != (z_before[i] > 0.0);
            if (crossed) {
                event_update(me, model, law, k, x);
                me->get_indicators(z);
            }
        }
        me->get_derivatives(dx);
        me->get_outputs(y);
        printf("me%s %d %d %d", me->tag, model, law, k);
        print_values("dx", dx, N_X);
        print_values("z", z, N_Z);
        print_values("y", y, N_OUT);
        putchar('\n');
        me->completed_step();
        for (int i = 0; i < N_X; i++) x[i] += ME_H * dx[i];
        memcpy(z_before, z, sizeof z);
    }
}

static fmi2Component me2_instance;

static void me2_set_time(double t) { check2(f2.setTime(me2_instance, t), "fmi2SetTime"); }
static void me2_set_inputs(const double *u) { check2(f2.setReal(me2_instance, IN_VR, N_IN, u), "fmi2SetReal"); }
static void me2_set_states(const double *x) {
    check2(f2.setStates(me2_instance, x, N_X), "fmi2SetContinuousStates");
}
static void me2_get_indicators(double *z) {
    check2(f2.getIndicators(me2_instance, z, N_Z), "fmi2GetEventIndicators");
}
static void me2_get_derivatives(double *dx) {
    check2(f2.getDerivatives(me2_instance, dx, N_X), "fmi2GetDerivatives");
}
static void me2_get_outputs(double *y) { check2(f2.getReal(me2_instance, OUT_VR, N_OUT, y), "fmi2GetReal"); }
static void me2_get_states(double *x) { check2(f2.getStates(me2_instance, x, N_X), "fmi2GetContinuousStates"); }
static void me2_event_update(int *flags) {
    fmi2EventInfo info;
    check2(f2.enterEventMode(me2_instance), "fmi2EnterEventMode");
    int rounds = 0;
    do {
        check2(f2.newDiscreteStates(me2_instance, &info), "fmi2NewDiscreteStates");
        if (++rounds > 10) fail("an FMI 2.0 event update does not settle");
    } while (info.newDiscreteStatesNeeded);
    check2(f2.enterContinuous(me2_instance), "fmi2EnterContinuousTimeMode");
    flags[0] = info.valuesOfContinuousStatesChanged;
    flags[1] = info.nominalsOfContinuousStatesChanged;
    flags[2] = info.terminateSimulation;
    flags[3] = info.nextEventTimeDefined;
}
static void me2_completed_step(void) {
    fmi2Boolean enter = fmi2False, terminate = fmi2False;
    check2(f2.completedStep(me2_instance, fmi2True, &enter, &terminate), "fmi2CompletedIntegratorStep");
}

static const MeDriver ME2 = {"2", me2_set_time, me2_set_inputs, me2_set_states, me2_get_indicators,
                             me2_get_derivatives, me2_get_outputs, me2_event_update, me2_get_states,
                             me2_completed_step};

static void model_exchange2(int model, int law) {
    double fz0;
    me2_instance = new2(fmi2ModelExchange, model, law, &fz0);
    model_exchange(&ME2, model, law, fz0);
    f2.freeInstance(me2_instance);
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

static struct {
    fmi3SetTimeTYPE *setTime;
    fmi3SetFloat64TYPE *setFloat64;
    fmi3GetFloat64TYPE *getFloat64;
    fmi3SetContinuousStatesTYPE *setStates;
    fmi3GetContinuousStatesTYPE *getStates;
    fmi3GetContinuousStateDerivativesTYPE *getDerivatives;
    fmi3GetEventIndicatorsTYPE *getIndicators;
    fmi3EnterEventModeTYPE *enterEventMode;
    fmi3UpdateDiscreteStatesTYPE *updateDiscreteStates;
    fmi3EnterContinuousTimeModeTYPE *enterContinuous;
    fmi3CompletedIntegratorStepTYPE *completedStep;
    fmi3Instance c;
} f3;

static void me3_set_time(double t) { check3(f3.setTime(f3.c, t), "fmi3SetTime"); }
static void me3_set_inputs(const double *u) {
    check3(f3.setFloat64(f3.c, IN_VR, N_IN, u, N_IN), "fmi3SetFloat64");
}
static void me3_set_states(const double *x) { check3(f3.setStates(f3.c, x, N_X), "fmi3SetContinuousStates"); }
static void me3_get_indicators(double *z) { check3(f3.getIndicators(f3.c, z, N_Z), "fmi3GetEventIndicators"); }
static void me3_get_derivatives(double *dx) {
    check3(f3.getDerivatives(f3.c, dx, N_X), "fmi3GetContinuousStateDerivatives");
}
static void me3_get_outputs(double *y) { check3(f3.getFloat64(f3.c, OUT_VR, N_OUT, y, N_OUT), "fmi3GetFloat64"); }
static void me3_get_states(double *x) { check3(f3.getStates(f3.c, x, N_X), "fmi3GetContinuousStates"); }
static void me3_event_update(int *flags) {
    fmi3Boolean again = fmi3False, terminate = fmi3False, nominals = fmi3False, values = fmi3False, timed = fmi3False;
    fmi3Float64 next = 0.0;
    check3(f3.enterEventMode(f3.c), "fmi3EnterEventMode");
    int rounds = 0;
    do {
        check3(f3.updateDiscreteStates(f3.c, &again, &terminate, &nominals, &values, &timed, &next),
               "fmi3UpdateDiscreteStates");
        if (++rounds > 10) fail("an FMI 3.0 event update does not settle");
    } while (again);
    check3(f3.enterContinuous(f3.c), "fmi3EnterContinuousTimeMode");
    flags[0] = values;
    flags[1] = nominals;
    flags[2] = terminate;
    flags[3] = timed;
}
static void me3_completed_step(void) {
    fmi3Boolean enter = fmi3False, terminate = fmi3False;
    check3(f3.completedStep(f3.c, fmi3True, &enter, &terminate), "fmi3CompletedIntegratorStep");
}

static const MeDriver ME3 = {"3", me3_set_time, me3_set_inputs, me3_set_states, me3_get_indicators,
                             me3_get_derivatives, me3_get_outputs, me3_event_update, me3_get_states,
                             me3_completed_step};

static void model_exchange3(int model, int law) {
    fmi3InstantiateModelExchangeTYPE *instantiate =
        (fmi3InstantiateModelExchangeTYPE *)need("fmi3InstantiateModelExchange");
    fmi3FreeInstanceTYPE *freeInstance = (fmi3FreeInstanceTYPE *)need("fmi3FreeInstance");
    fmi3SetInt64TYPE *setInt64 = (fmi3SetInt64TYPE *)need("fmi3SetInt64");
    fmi3EnterInitializationModeTYPE *enterInit =
        (fmi3EnterInitializationModeTYPE *)need("fmi3EnterInitializationMode");
    fmi3ExitInitializationModeTYPE *exitInit = (fmi3ExitInitializationModeTYPE *)need("fmi3ExitInitializationMode");
    f3.setTime = (fmi3SetTimeTYPE *)need("fmi3SetTime");
    f3.setFloat64 = (fmi3SetFloat64TYPE *)need("fmi3SetFloat64");
    f3.getFloat64 = (fmi3GetFloat64TYPE *)need("fmi3GetFloat64");
    f3.setStates = (fmi3SetContinuousStatesTYPE *)need("fmi3SetContinuousStates");
    f3.getStates = (fmi3GetContinuousStatesTYPE *)need("fmi3GetContinuousStates");
    f3.getDerivatives = (fmi3GetContinuousStateDerivativesTYPE *)need("fmi3GetContinuousStateDerivatives");
    f3.getIndicators = (fmi3GetEventIndicatorsTYPE *)need("fmi3GetEventIndicators");
    f3.enterEventMode = (fmi3EnterEventModeTYPE *)need("fmi3EnterEventMode");
    f3.updateDiscreteStates = (fmi3UpdateDiscreteStatesTYPE *)need("fmi3UpdateDiscreteStates");
    f3.enterContinuous = (fmi3EnterContinuousTimeModeTYPE *)need("fmi3EnterContinuousTimeMode");
    f3.completedStep = (fmi3CompletedIntegratorStepTYPE *)need("fmi3CompletedIntegratorStep");

    f3.c = instantiate("platforms", guid, NULL, fmi3False, fmi3False, NULL, logger3);
    if (!f3.c) fail("fmi3InstantiateModelExchange refused the instance");
    const fmi3ValueReference vr[2] = {VR_MODEL, VR_FRICTION};
    const fmi3Int64 value[2] = {model, law};
    check3(setInt64(f3.c, vr, 2, value, 2), "fmi3SetInt64");
    check3(enterInit(f3.c, fmi3False, 0.0, 0.0, fmi3False, 0.0), "fmi3EnterInitializationMode");
    double fz0;
    const fmi3ValueReference fz0_vr = VR_FZ0;
    check3(f3.getFloat64(f3.c, &fz0_vr, 1, &fz0, 1), "fmi3GetFloat64(Fz0)");
    check3(exitInit(f3.c), "fmi3ExitInitializationMode");
    model_exchange(&ME3, model, law, fz0);
    freeInstance(f3.c);
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
            model_exchange3(model, law);
            stiff_light2(model, law);
        }
    if (timing)
        for (int model = 1; model <= 4; model++) printf("time %d %.1f\n", model, cost_per_step(model));
    fflush(stdout);
    return 0;
}
