/*
 * benches/native_host/host.c -- one native co-simulation host with two drivers, FMI 2.0
 * and FMI 3.0, so that the cost of a TireLag step can be compared across the two
 * interfaces of the same library. benches/fmi_versions builds and runs it; see there.
 *
 * A full co-simulation step is, in either version:
 *     FMI 2.0: fmi2SetReal(vx vy steerRate vsx Fz)     fmi2DoStep(t, h)  fmi2GetReal(9 outputs)
 *     FMI 3.0: fmi3SetFloat64(vx vy steerRate vsx Fz)  fmi3DoStep(t, h)  fmi3GetFloat64(9 outputs)
 * one call each, value references 1..5 and 11..19. Every status is checked, and so are
 * fmi3DoStep's eventHandlingNeeded, terminateSimulation and earlyReturn. The tire model is
 * chosen before initialisation with fmi2SetInteger / fmi3SetInt64 (tireModel, vr 100) and
 * read back.
 *
 * Inputs of step k (t = k h, h = 1 ms by default), the protocol of the shared yardstick:
 *     vx = 10 + 0.001 (k mod 1000)  [constant: 10]      vy = 0.1 sin(t)
 *     steerRate = 0.05 cos(t)                           vsx = 0.01 sin(t)
 *     Fz = 50000 (1 + 0.02 sin(2t))  [constant: 50000]
 * They are tabulated for 8000 steps before timing and the table is cycled, so no sin/cos
 * runs in the timed loop.
 *
 * Modes:
 *   host -V 2|3 [options] LIB.so
 *       Timing. One warm-up pass of N steps, then R timed passes of N steps on the same
 *       instance (time runs on). Prints one line
 *           <label> <median ns per step> min <ns> max <ns> ... fy_sum <hex float>
 *       fy_sum is the exact sum of Fy over all passes, printed bit for bit (%a): the same
 *       arguments give the same fy_sum in either version if both run the same physics.
 *   host -C [options] FMI2_LIB.so FMI3_LIB.so
 *       Comparison. Runs an FMI 2.0 instance and an FMI 3.0 instance in lock step for N
 *       steps on the same inputs and requires all 9 outputs to be bit-identical after every
 *       step (and fmi3DoStep's lastSuccessfulTime to be the end of the step). Prints
 *           compare <steps> identical fy_sum <hex float> ...
 *       or names the first step and output that differ and exits with status 1.
 *
 * Options:
 *   -m MODEL     tireModel 1..4 (RLT, DDT, SecondOrder, RingBody); default: not set (DDT)
 *   -c           vx and Fz constant (default: varying every step)
 *   -n N         steps per pass (default 20000)
 *   -r R         timed passes (default 5)
 *   -h H         communication step size in s (default 0.001)
 *   -M VR        value reference of tireModel (default 100)
 *   -i VR:VALUE  set another selector (Integer / Enumeration, e.g. friction 121:1); repeatable
 *   -g TOKEN     FMI 2 guid and FMI 3 instantiationToken (default TireLag's)
 *   -G TOKEN     FMI 3 instantiationToken only (after -g)
 *   -l LABEL     first word of the timing line (default fmi2 / fmi3)
 *
 * Anything that fails (dlopen, a missing symbol, a status other than OK, a refused
 * instantiation, a log message of warning or worse) is printed to stderr and ends the
 * program with status 1.
 *
 * Build: cc -O2 -I<fmpy>/c-code host.c -o host -ldl -lm  (headers of the fmpy wheel)
 */

#define _XOPEN_SOURCE 700 /* realpath, getopt, clock_gettime */
#include <dlfcn.h>
#include <errno.h>
#include <inttypes.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "fmi2Functions.h"
#include "fmi3Functions.h"

#define DEFAULT_TOKEN "{6b1f6a52-8c3e-4f0e-9d2a-5e7c1b9a4d31}"
#define N_IN 5
#define N_OUT 9
#define TABLE_LEN 8000 /* a whole number of vx's 1000-step ramps */
#define MAX_SELECTORS 8

static const unsigned int IN_VR[N_IN] = {1, 2, 3, 4, 5};
static const unsigned int OUT_VR[N_OUT] = {11, 12, 13, 14, 15, 16, 17, 18, 19};
static const char *const OUT_NAME[N_OUT] = {"Fx", "Fy", "Mz", "My", "alphaT", "kappaT", "deflX", "deflY", "deflPsi"};

/* ------------------------------------------------------------------ common */

typedef struct {
    int model;            /* 0: leave the default */
    unsigned int model_vr;
    unsigned int sel_vr[MAX_SELECTORS];
    long long sel_value[MAX_SELECTORS];
    int n_sel;
    const char *token2; /* FMI 2 guid */
    const char *token3; /* FMI 3 instantiationToken */
    double h;
    int constant;
    long long steps;
    int reps;
} Config;

static void fail(const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    fputs("host: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    exit(1);
}

static void *need(void *lib, const char *name) {
    dlerror();
    void *p = dlsym(lib, name);
    if (!p) {
        const char *why = dlerror();
        fail("dlsym(%s): %s", name, why ? why : "NULL");
    }
    return p;
}

static void *open_library(const char *path, char *resolved) {
    if (!realpath(path, resolved)) fail("%s: %s", path, strerror(errno));
    void *lib = dlopen(resolved, RTLD_NOW | RTLD_LOCAL);
    if (!lib) fail("dlopen(%s): %s", resolved, dlerror());
    return lib;
}

/* The unpacked FMU's resources directory (LIB is <fmu>/binaries/<platform>/<id>.so), with a
 * trailing '/', or "" if there is none. */
static void resources_of(const char *lib_path, char *out, size_t size) {
    char dir[PATH_MAX];
    snprintf(dir, sizeof dir, "%s", lib_path);
    for (int up = 0; up < 3; up++) {
        char *slash = strrchr(dir, '/');
        if (!slash) {
            out[0] = '\0';
            return;
        }
        *slash = '\0';
    }
    struct stat st;
    if (snprintf(out, size, "%s/resources/", dir) >= (int)size || stat(out, &st) != 0 || !S_ISDIR(st.st_mode))
        out[0] = '\0';
}

static void fill_inputs(const Config *cfg, double *table) {
    for (long long k = 0; k < TABLE_LEN; k++) {
        const double t = (double)k * cfg->h;
        double *u = &table[N_IN * k];
        u[0] = cfg->constant ? 10.0 : 10.0 + 0.001 * (double)(k % 1000);
        u[1] = 0.1 * sin(t);
        u[2] = 0.05 * cos(t);
        u[3] = 0.01 * sin(t);
        u[4] = cfg->constant ? 50000.0 : 50000.0 * (1.0 + 0.02 * sin(2.0 * t));
    }
}

static double clock_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return 1e9 * (double)ts.tv_sec + (double)ts.tv_nsec;
}

static int by_value(const void *a, const void *b) {
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static const char *status_name(int s) {
    static const char *const names[] = {"OK", "Warning", "Discard", "Error", "Fatal", "Pending"};
    return s >= 0 && s <= 5 ? names[s] : "unknown status";
}

/* ------------------------------------------------------------------ FMI 2.0 driver */

typedef struct {
    void *lib;
    fmi2GetVersionTYPE *getVersion;
    fmi2InstantiateTYPE *instantiate;
    fmi2FreeInstanceTYPE *freeInstance;
    fmi2SetupExperimentTYPE *setupExperiment;
    fmi2EnterInitializationModeTYPE *enterInit;
    fmi2ExitInitializationModeTYPE *exitInit;
    fmi2TerminateTYPE *terminate;
    fmi2SetIntegerTYPE *setInteger;
    fmi2GetIntegerTYPE *getInteger;
    fmi2SetRealTYPE *setReal;
    fmi2GetRealTYPE *getReal;
    fmi2DoStepTYPE *doStep;
    fmi2Component c;
} Fmi2;

static void fmi2_logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                 fmi2String message, ...) {
    (void)env;
    if (status == fmi2OK) return;
    va_list ap;
    va_start(ap, message);
    fprintf(stderr, "host: FMI 2.0 %s [%s] %s: ", instance ? instance : "?", category ? category : "?",
            status_name(status));
    vfprintf(stderr, message ? message : "", ap);
    fputc('\n', stderr);
    va_end(ap);
    if (status != fmi2Discard) exit(1); /* a warning or an error fails the run */
}

#define CHECK2(call, what)                                                         \
    do {                                                                           \
        const fmi2Status s_ = (call);                                              \
        if (s_ != fmi2OK) fail("FMI 2.0 %s returned %s", what, status_name(s_));  \
    } while (0)

static void fmi2_open(Fmi2 *f, const char *path, const Config *cfg) {
    static const fmi2CallbackFunctions callbacks = {fmi2_logger, calloc, free, NULL, NULL};
    char resolved[PATH_MAX], resources[PATH_MAX], uri[PATH_MAX + 16];
    f->lib = open_library(path, resolved);
    f->getVersion = (fmi2GetVersionTYPE *)need(f->lib, "fmi2GetVersion");
    f->instantiate = (fmi2InstantiateTYPE *)need(f->lib, "fmi2Instantiate");
    f->freeInstance = (fmi2FreeInstanceTYPE *)need(f->lib, "fmi2FreeInstance");
    f->setupExperiment = (fmi2SetupExperimentTYPE *)need(f->lib, "fmi2SetupExperiment");
    f->enterInit = (fmi2EnterInitializationModeTYPE *)need(f->lib, "fmi2EnterInitializationMode");
    f->exitInit = (fmi2ExitInitializationModeTYPE *)need(f->lib, "fmi2ExitInitializationMode");
    f->terminate = (fmi2TerminateTYPE *)need(f->lib, "fmi2Terminate");
    f->setInteger = (fmi2SetIntegerTYPE *)need(f->lib, "fmi2SetInteger");
    f->getInteger = (fmi2GetIntegerTYPE *)need(f->lib, "fmi2GetInteger");
    f->setReal = (fmi2SetRealTYPE *)need(f->lib, "fmi2SetReal");
    f->getReal = (fmi2GetRealTYPE *)need(f->lib, "fmi2GetReal");
    f->doStep = (fmi2DoStepTYPE *)need(f->lib, "fmi2DoStep");

    const char *version = f->getVersion();
    if (!version || strcmp(version, fmi2Version) != 0) fail("fmi2GetVersion gave \"%s\", not \"%s\"", version ? version : "(null)", fmi2Version);

    resources_of(resolved, resources, sizeof resources);
    snprintf(uri, sizeof uri, "file://%s", resources[0] ? resources : "/nonexistent/");
    f->c = f->instantiate("fmi2", fmi2CoSimulation, cfg->token2, uri, &callbacks, fmi2False, fmi2False);
    if (!f->c) fail("fmi2Instantiate(CoSimulation, \"%s\") returned NULL", cfg->token2);

    if (cfg->model) {
        const fmi2Integer value = cfg->model;
        CHECK2(f->setInteger(f->c, &cfg->model_vr, 1, &value), "fmi2SetInteger(tireModel)");
    }
    for (int i = 0; i < cfg->n_sel; i++) {
        const fmi2Integer value = (fmi2Integer)cfg->sel_value[i];
        CHECK2(f->setInteger(f->c, &cfg->sel_vr[i], 1, &value), "fmi2SetInteger(-i)");
    }
    CHECK2(f->setupExperiment(f->c, fmi2False, 0.0, 0.0, fmi2False, 0.0), "fmi2SetupExperiment");
    CHECK2(f->enterInit(f->c), "fmi2EnterInitializationMode");
    CHECK2(f->exitInit(f->c), "fmi2ExitInitializationMode");
    if (cfg->model) { /* read back in Step Mode: the model the steps will run */
        fmi2Integer back = -1;
        CHECK2(f->getInteger(f->c, &cfg->model_vr, 1, &back), "fmi2GetInteger(tireModel)");
        if (back != cfg->model) fail("FMI 2.0 tireModel reads back %d after setting %d", (int)back, cfg->model);
    }
}

/* One full co-simulation step (not used in the timed loop, which spells it out). */
static void fmi2_step(Fmi2 *f, long long k, double h, const double *u, double *y) {
    CHECK2(f->setReal(f->c, IN_VR, N_IN, u), "fmi2SetReal(inputs)");
    CHECK2(f->doStep(f->c, (double)k * h, h, fmi2True), "fmi2DoStep");
    CHECK2(f->getReal(f->c, OUT_VR, N_OUT, y), "fmi2GetReal(outputs)");
}

static void fmi2_close(Fmi2 *f) {
    CHECK2(f->terminate(f->c), "fmi2Terminate");
    f->freeInstance(f->c);
    if (dlclose(f->lib) != 0) fail("dlclose: %s", dlerror());
}

/* Runs 1 + reps passes; times[] gets the ns per step of the timed ones. */
static double fmi2_time(Fmi2 *f, const Config *cfg, const double *table, double *times) {
    const fmi2Component c = f->c;
    const double h = cfg->h;
    double y[N_OUT], fy_sum = 0.0;
    long long k = 0;
    for (int pass = 0; pass <= cfg->reps; pass++) {
        const double start = clock_ns();
        for (long long i = 0; i < cfg->steps; i++, k++) {
            const double *u = &table[N_IN * (k % TABLE_LEN)];
            fmi2Status s;
            if ((s = f->setReal(c, IN_VR, N_IN, u)) != fmi2OK) fail("FMI 2.0 fmi2SetReal at step %lld: %s", k, status_name(s));
            if ((s = f->doStep(c, (double)k * h, h, fmi2True)) != fmi2OK) fail("FMI 2.0 fmi2DoStep at step %lld: %s", k, status_name(s));
            if ((s = f->getReal(c, OUT_VR, N_OUT, y)) != fmi2OK) fail("FMI 2.0 fmi2GetReal at step %lld: %s", k, status_name(s));
            fy_sum += y[1];
        }
        const double elapsed = clock_ns() - start;
        if (pass > 0) times[pass - 1] = elapsed / (double)cfg->steps; /* pass 0 warms up */
    }
    return fy_sum;
}

/* ------------------------------------------------------------------ FMI 3.0 driver */

typedef struct {
    void *lib;
    fmi3GetVersionTYPE *getVersion;
    fmi3InstantiateCoSimulationTYPE *instantiate;
    fmi3FreeInstanceTYPE *freeInstance;
    fmi3EnterInitializationModeTYPE *enterInit;
    fmi3ExitInitializationModeTYPE *exitInit;
    fmi3TerminateTYPE *terminate;
    fmi3SetInt64TYPE *setInt64;
    fmi3GetInt64TYPE *getInt64;
    fmi3SetFloat64TYPE *setFloat64;
    fmi3GetFloat64TYPE *getFloat64;
    fmi3DoStepTYPE *doStep;
    fmi3Instance c;
} Fmi3;

static void fmi3_logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env;
    if (status == fmi3OK) return;
    fprintf(stderr, "host: FMI 3.0 [%s] %s: %s\n", category ? category : "?", status_name(status), message ? message : "");
    if (status != fmi3Discard) exit(1);
}

#define CHECK3(call, what)                                                         \
    do {                                                                           \
        const fmi3Status s_ = (call);                                              \
        if (s_ != fmi3OK) fail("FMI 3.0 %s returned %s", what, status_name(s_));  \
    } while (0)

static void fmi3_open(Fmi3 *f, const char *path, const Config *cfg) {
    char resolved[PATH_MAX], resources[PATH_MAX];
    f->lib = open_library(path, resolved);
    f->getVersion = (fmi3GetVersionTYPE *)need(f->lib, "fmi3GetVersion");
    f->instantiate = (fmi3InstantiateCoSimulationTYPE *)need(f->lib, "fmi3InstantiateCoSimulation");
    f->freeInstance = (fmi3FreeInstanceTYPE *)need(f->lib, "fmi3FreeInstance");
    f->enterInit = (fmi3EnterInitializationModeTYPE *)need(f->lib, "fmi3EnterInitializationMode");
    f->exitInit = (fmi3ExitInitializationModeTYPE *)need(f->lib, "fmi3ExitInitializationMode");
    f->terminate = (fmi3TerminateTYPE *)need(f->lib, "fmi3Terminate");
    f->setInt64 = (fmi3SetInt64TYPE *)need(f->lib, "fmi3SetInt64");
    f->getInt64 = (fmi3GetInt64TYPE *)need(f->lib, "fmi3GetInt64");
    f->setFloat64 = (fmi3SetFloat64TYPE *)need(f->lib, "fmi3SetFloat64");
    f->getFloat64 = (fmi3GetFloat64TYPE *)need(f->lib, "fmi3GetFloat64");
    f->doStep = (fmi3DoStepTYPE *)need(f->lib, "fmi3DoStep");

    const char *version = f->getVersion();
    if (!version || strcmp(version, fmi3Version) != 0) fail("fmi3GetVersion gave \"%s\", not \"%s\"", version ? version : "(null)", fmi3Version);

    resources_of(resolved, resources, sizeof resources);
    /* visible, loggingOn, eventModeUsed, earlyReturnAllowed all false; no intermediate update */
    f->c = f->instantiate("fmi3", cfg->token3, resources[0] ? resources : NULL, fmi3False, fmi3False, fmi3False,
                          fmi3False, NULL, 0, NULL, fmi3_logger, NULL);
    if (!f->c) fail("fmi3InstantiateCoSimulation(\"%s\") returned NULL", cfg->token3);

    if (cfg->model) {
        const fmi3Int64 value = cfg->model;
        CHECK3(f->setInt64(f->c, &cfg->model_vr, 1, &value, 1), "fmi3SetInt64(tireModel)");
    }
    for (int i = 0; i < cfg->n_sel; i++) {
        const fmi3Int64 value = cfg->sel_value[i];
        CHECK3(f->setInt64(f->c, &cfg->sel_vr[i], 1, &value, 1), "fmi3SetInt64(-i)");
    }
    CHECK3(f->enterInit(f->c, fmi3False, 0.0, 0.0, fmi3False, 0.0), "fmi3EnterInitializationMode");
    CHECK3(f->exitInit(f->c), "fmi3ExitInitializationMode");
    if (cfg->model) {
        fmi3Int64 back = -1;
        CHECK3(f->getInt64(f->c, &cfg->model_vr, 1, &back, 1), "fmi3GetInt64(tireModel)");
        if (back != cfg->model) fail("FMI 3.0 tireModel reads back %" PRId64 " after setting %d", back, cfg->model);
    }
}

static void fmi3_step(Fmi3 *f, long long k, double h, const double *u, double *y, double *last) {
    fmi3Boolean event = fmi3True, terminate = fmi3True, early = fmi3True;
    *last = NAN;
    CHECK3(f->setFloat64(f->c, IN_VR, N_IN, u, N_IN), "fmi3SetFloat64(inputs)");
    CHECK3(f->doStep(f->c, (double)k * h, h, fmi3True, &event, &terminate, &early, last), "fmi3DoStep");
    if (event || terminate || early)
        fail("FMI 3.0 fmi3DoStep at step %lld: eventHandlingNeeded %d terminateSimulation %d earlyReturn %d", k, event,
             terminate, early);
    CHECK3(f->getFloat64(f->c, OUT_VR, N_OUT, y, N_OUT), "fmi3GetFloat64(outputs)");
}

static void fmi3_close(Fmi3 *f) {
    CHECK3(f->terminate(f->c), "fmi3Terminate");
    f->freeInstance(f->c);
    if (dlclose(f->lib) != 0) fail("dlclose: %s", dlerror());
}

static double fmi3_time(Fmi3 *f, const Config *cfg, const double *table, double *times) {
    const fmi3Instance c = f->c;
    const double h = cfg->h;
    double y[N_OUT], fy_sum = 0.0, last;
    fmi3Boolean event, terminate, early;
    long long k = 0;
    for (int pass = 0; pass <= cfg->reps; pass++) {
        const double start = clock_ns();
        for (long long i = 0; i < cfg->steps; i++, k++) {
            const double *u = &table[N_IN * (k % TABLE_LEN)];
            fmi3Status s;
            if ((s = f->setFloat64(c, IN_VR, N_IN, u, N_IN)) != fmi3OK) fail("FMI 3.0 fmi3SetFloat64 at step %lld: %s", k, status_name(s));
            if ((s = f->doStep(c, (double)k * h, h, fmi3True, &event, &terminate, &early, &last)) != fmi3OK)
                fail("FMI 3.0 fmi3DoStep at step %lld: %s", k, status_name(s));
            if (event | terminate | early)
                fail("FMI 3.0 fmi3DoStep at step %lld: eventHandlingNeeded %d terminateSimulation %d earlyReturn %d", k,
                     event, terminate, early);
            if ((s = f->getFloat64(c, OUT_VR, N_OUT, y, N_OUT)) != fmi3OK) fail("FMI 3.0 fmi3GetFloat64 at step %lld: %s", k, status_name(s));
            fy_sum += y[1];
        }
        const double elapsed = clock_ns() - start;
        if (pass > 0) times[pass - 1] = elapsed / (double)cfg->steps;
    }
    return fy_sum;
}

/* ------------------------------------------------------------------ modes */

static const char *model_name(int m) {
    static const char *const names[] = {"default", "RLT", "DDT", "SecondOrder", "RingBody"};
    return m >= 0 && m <= 4 ? names[m] : "?";
}

static int time_one(int version, const char *path, const Config *cfg, const char *label) {
    double *table = malloc(sizeof(double) * N_IN * TABLE_LEN);
    double *times = malloc(sizeof(double) * (size_t)cfg->reps);
    if (!table || !times) fail("out of memory");
    fill_inputs(cfg, table);

    double fy_sum;
    if (version == 2) {
        Fmi2 f;
        fmi2_open(&f, path, cfg);
        fy_sum = fmi2_time(&f, cfg, table, times);
        fmi2_close(&f);
    } else {
        Fmi3 f;
        fmi3_open(&f, path, cfg);
        fy_sum = fmi3_time(&f, cfg, table, times);
        fmi3_close(&f);
    }
    qsort(times, (size_t)cfg->reps, sizeof(double), by_value);
    const int r = cfg->reps;
    const double median = r % 2 ? times[r / 2] : 0.5 * (times[r / 2 - 1] + times[r / 2]);
    printf("%s %.1f min %.1f max %.1f fmi %d.0 model %s vx,Fz %s steps %lld reps %d h %g fy_sum %a\n",
           label ? label : (version == 2 ? "fmi2" : "fmi3"), median, times[0], times[r - 1], version,
           model_name(cfg->model), cfg->constant ? "constant" : "varying", cfg->steps, r, cfg->h, fy_sum);
    free(table);
    free(times);
    return 0;
}

static int compare(const char *path2, const char *path3, const Config *cfg) {
    double *table = malloc(sizeof(double) * N_IN * TABLE_LEN);
    if (!table) fail("out of memory");
    fill_inputs(cfg, table);

    Fmi2 f2;
    Fmi3 f3;
    fmi2_open(&f2, path2, cfg);
    fmi3_open(&f3, path3, cfg);
    double y2[N_OUT], y3[N_OUT], fy_sum = 0.0, max_abs_fy = 0.0;
    long long inexact_time = 0; /* steps whose lastSuccessfulTime is not t + h to the bit */
    for (long long k = 0; k < cfg->steps; k++) {
        const double *u = &table[N_IN * (k % TABLE_LEN)];
        double last;
        fmi2_step(&f2, k, cfg->h, u, y2);
        fmi3_step(&f3, k, cfg->h, u, y3, &last);
        const double end = (double)k * cfg->h + cfg->h; /* currentCommunicationPoint + communicationStepSize */
        if (!(fabs(last - end) <= 1e-12 * fmax(1.0, fabs(end))))
            fail("FMI 3.0 fmi3DoStep at step %lld (t = %.17g, h = %g): lastSuccessfulTime %.17g, expected %.17g", k,
                 (double)k * cfg->h, cfg->h, last, end);
        inexact_time += last != end;
        if (memcmp(y2, y3, sizeof y2) != 0) {
            for (int i = 0; i < N_OUT; i++)
                if (memcmp(&y2[i], &y3[i], sizeof(double)) != 0)
                    fprintf(stderr, "host: step %lld (t = %.17g): %s FMI 2.0 %.17g (%a), FMI 3.0 %.17g (%a)\n", k, end,
                            OUT_NAME[i], y2[i], y2[i], y3[i], y3[i]);
            fail("FMI 2.0 and FMI 3.0 outputs differ (model %s, vx,Fz %s)", model_name(cfg->model),
                 cfg->constant ? "constant" : "varying");
        }
        fy_sum += y2[1];
        max_abs_fy = fmax(max_abs_fy, fabs(y2[1]));
    }
    fmi2_close(&f2);
    fmi3_close(&f3);
    if (!(max_abs_fy > 0.0)) fail("Fy stayed 0: the comparison proves nothing");
    printf("compare %lld identical fy_sum %a max|Fy| %.6g model %s vx,Fz %s lastSuccessfulTime %s\n", cfg->steps,
           fy_sum, max_abs_fy, model_name(cfg->model), cfg->constant ? "constant" : "varying",
           inexact_time ? "within 1e-12 (not bit-exact)" : "exact");
    free(table);
    return 0;
}

static void usage(const char *argv0) {
    fprintf(stderr,
            "usage: %s -V 2|3 [options] LIB.so            (timing)\n"
            "       %s -C [options] FMI2_LIB.so FMI3_LIB.so (bitwise comparison)\n"
            "options: -m MODEL(1-4) -c (constant vx, Fz) -n STEPS -r PASSES -h STEP -M MODEL_VR -i VR:VALUE -g TOKEN -G FMI3_TOKEN -l LABEL\n",
            argv0, argv0);
    exit(2);
}

static long long parse_int(const char *s, const char *what) {
    char *end;
    errno = 0;
    const long long v = strtoll(s, &end, 10);
    if (errno || end == s || *end) fail("bad %s: \"%s\"", what, s);
    return v;
}

int main(int argc, char **argv) {
    Config cfg = {.model = 0, .model_vr = 100, .n_sel = 0, .token2 = DEFAULT_TOKEN, .token3 = DEFAULT_TOKEN, .h = 1e-3, .constant = 0,
                  .steps = 20000, .reps = 5};
    int version = 0, comparing = 0;
    const char *label = NULL;
    int opt;
    while ((opt = getopt(argc, argv, "V:Cm:cn:r:h:M:i:g:G:l:")) != -1) {
        switch (opt) {
        case 'V': version = (int)parse_int(optarg, "-V"); break;
        case 'C': comparing = 1; break;
        case 'm': cfg.model = (int)parse_int(optarg, "-m"); break;
        case 'c': cfg.constant = 1; break;
        case 'n': cfg.steps = parse_int(optarg, "-n"); break;
        case 'r': cfg.reps = (int)parse_int(optarg, "-r"); break;
        case 'h': {
            char *end;
            cfg.h = strtod(optarg, &end);
            if (end == optarg || *end || !(cfg.h > 0) || !isfinite(cfg.h)) fail("bad -h: \"%s\"", optarg);
            break;
        }
        case 'M': cfg.model_vr = (unsigned int)parse_int(optarg, "-M"); break;
        case 'i': {
            char *colon = strchr(optarg, ':');
            if (cfg.n_sel == MAX_SELECTORS || !colon) fail("bad -i VR:VALUE: \"%s\"", optarg);
            *colon = '\0';
            cfg.sel_vr[cfg.n_sel] = (unsigned int)parse_int(optarg, "-i VR");
            cfg.sel_value[cfg.n_sel] = parse_int(colon + 1, "-i VALUE");
            cfg.n_sel++;
            break;
        }
        case 'g': cfg.token2 = cfg.token3 = optarg; break;
        case 'G': cfg.token3 = optarg; break;
        case 'l': label = optarg; break;
        default: usage(argv[0]);
        }
    }
    if (cfg.model < 0 || cfg.model > 4) fail("-m must be 1..4");
    if (cfg.steps < 1 || cfg.reps < 1) fail("-n and -r must be positive");
    if (comparing) {
        if (version || optind != argc - 2) usage(argv[0]);
        return compare(argv[optind], argv[optind + 1], &cfg);
    }
    if ((version != 2 && version != 3) || optind != argc - 1) usage(argv[0]);
    return time_one(version, argv[optind], &cfg, label);
}
