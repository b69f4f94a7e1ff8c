/* A small FMI 2.0 Co-Simulation master, one source for Linux and Windows: it loads an
 * FMU's binary (dlopen or LoadLibrary), runs the script given and writes what every call
 * returned, numbers as the hexadecimal bits of their IEEE doubles. The same script run
 * on the linux64 binary of an FMU and on its win64 (or linux-aarch64) binary must write
 * the same file, byte for byte (tests/test_platforms.py). Nothing here is the project's code: it is the importer's side.
 *
 * Usage: master BINARY GUID RESOURCE_URI SCRIPT OUT
 *
 * The script, one command per line (numbers as 16 hex digits of their bits):
 *   instantiate NAME        fmi2Instantiate (Co-Simulation, logging on)
 *   setup START             fmi2SetupExperiment without tolerance or stop time
 *   enter | exit            fmi2Enter/ExitInitializationMode
 *   real VR BITS            fmi2SetReal of one variable
 *   int VR VALUE            fmi2SetInteger of one variable
 *   get VR...               fmi2GetReal of these variables
 *   step T H                fmi2DoStep
 *   save                    fmi2GetFMUstate, then fmi2SerializeFMUstate (kept in memory)
 *   restore                 fmi2DeSerializeFMUstate of the saved bytes, then fmi2SetFMUstate
 *   last                    fmi2GetRealStatus(fmi2LastSuccessfulTime)
 *   free                    fmi2Terminate, then fmi2FreeInstance
 * After a step that returns fmi2Discard or worse only get, last and free are run (the
 * FMI state machine allows nothing else); the others are written as skipped. A step
 * that returns fmi2Warning was made (an estimator's lost filter says so), and the
 * master goes on. */

#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
#define LOAD(path) ((void *)LoadLibraryA(path))
#define SYMBOL(lib, name) ((void *)GetProcAddress((HMODULE)(lib), name))
#else
#include <dlfcn.h>
#define LOAD(path) dlopen(path, RTLD_NOW | RTLD_LOCAL)
#define SYMBOL(lib, name) dlsym(lib, name)
#endif

typedef void *Component;
typedef void *State;
typedef unsigned int ValueReference;
typedef int Status;
typedef void (*Logger)(void *, const char *, Status, const char *, const char *, ...);
typedef struct {
    Logger logger;
    void *(*allocate)(size_t, size_t);
    void (*release)(void *);
    void (*step_finished)(void *, Status);
    void *environment;
} Callbacks;

static Component (*Instantiate)(const char *, int, const char *, const char *, const Callbacks *, int, int);
static Status (*SetupExperiment)(Component, int, double, double, int, double);
static Status (*EnterInitializationMode)(Component);
static Status (*ExitInitializationMode)(Component);
static Status (*SetReal)(Component, const ValueReference *, size_t, const double *);
static Status (*SetInteger)(Component, const ValueReference *, size_t, const int *);
static Status (*GetReal)(Component, const ValueReference *, size_t, double *);
static Status (*DoStep)(Component, double, double, int);
static Status (*GetFMUstate)(Component, State *);
static Status (*SetFMUstate)(Component, State);
static Status (*FreeFMUstate)(Component, State *);
static Status (*SerializedFMUstateSize)(Component, State, size_t *);
static Status (*SerializeFMUstate)(Component, State, char *, size_t);
static Status (*DeSerializeFMUstate)(Component, const char *, size_t, State *);
static Status (*GetRealStatus)(Component, int, double *);
static Status (*Terminate)(Component);
static void (*FreeInstance)(Component);

/* The FMU's messages go to stderr: not compared (they are for the reader of a failure). */
static void logger(void *env, const char *instance, Status status, const char *category, const char *message, ...) {
    va_list args;
    (void)env;
    fprintf(stderr, "[%s %d %s] ", instance ? instance : "?", status, category ? category : "?");
    va_start(args, message);
    vfprintf(stderr, message, args);
    va_end(args);
    fputc('\n', stderr);
}

static void *symbol(void *lib, const char *name) {
    void *f = SYMBOL(lib, name);
    if (!f) {
        fprintf(stderr, "master: the binary does not export %s\n", name);
        exit(2);
    }
    return f;
}

static double from_bits(const char *hex) {
    uint64_t bits = strtoull(hex, NULL, 16);
    double x;
    memcpy(&x, &bits, sizeof x);
    return x;
}

static void write_bits(FILE *out, double x) {
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    fprintf(out, " %016" PRIx64, bits);
}

int main(int argc, char **argv) {
    if (argc != 6) {
        fprintf(stderr, "usage: master BINARY GUID RESOURCE_URI SCRIPT OUT\n");
        return 2;
    }
    void *lib = LOAD(argv[1]);
    if (!lib) {
        fprintf(stderr, "master: cannot load %s\n", argv[1]);
        return 2;
    }
    *(void **)&Instantiate = symbol(lib, "fmi2Instantiate");
    *(void **)&SetupExperiment = symbol(lib, "fmi2SetupExperiment");
    *(void **)&EnterInitializationMode = symbol(lib, "fmi2EnterInitializationMode");
    *(void **)&ExitInitializationMode = symbol(lib, "fmi2ExitInitializationMode");
    *(void **)&SetReal = symbol(lib, "fmi2SetReal");
    *(void **)&SetInteger = symbol(lib, "fmi2SetInteger");
    *(void **)&GetReal = symbol(lib, "fmi2GetReal");
    *(void **)&DoStep = symbol(lib, "fmi2DoStep");
    *(void **)&GetFMUstate = symbol(lib, "fmi2GetFMUstate");
    *(void **)&SetFMUstate = symbol(lib, "fmi2SetFMUstate");
    *(void **)&FreeFMUstate = symbol(lib, "fmi2FreeFMUstate");
    *(void **)&SerializedFMUstateSize = symbol(lib, "fmi2SerializedFMUstateSize");
    *(void **)&SerializeFMUstate = symbol(lib, "fmi2SerializeFMUstate");
    *(void **)&DeSerializeFMUstate = symbol(lib, "fmi2DeSerializeFMUstate");
    *(void **)&GetRealStatus = symbol(lib, "fmi2GetRealStatus");
    *(void **)&Terminate = symbol(lib, "fmi2Terminate");
    *(void **)&FreeInstance = symbol(lib, "fmi2FreeInstance");

    FILE *script = fopen(argv[4], "r");
    FILE *out = fopen(argv[5], "w");
    if (!script || !out) {
        fprintf(stderr, "master: cannot open the script or the output\n");
        return 2;
    }
    Callbacks callbacks = {logger, calloc, free, NULL, NULL};
    Component c = NULL;
    char *saved = NULL;
    size_t saved_size = 0;
    int failed = 0;
    static char line[1 << 16];
    while (fgets(line, sizeof line, script)) {
        char *command = strtok(line, " \n");
        if (!command) continue;
        fprintf(out, "%s", command);
        int allowed_after_failure = !strcmp(command, "get") || !strcmp(command, "last") || !strcmp(command, "free");
        if (failed && !allowed_after_failure) {
            fprintf(out, " skipped\n");
            continue;
        }
        Status s = 0;
        if (!strcmp(command, "instantiate")) {
            c = Instantiate(strtok(NULL, " \n"), 1, argv[2], argv[3], &callbacks, 0, 1);
            failed = 0;
            fprintf(out, " %s\n", c ? "ok" : "null");
            if (!c) {
                fprintf(stderr, "master: fmi2Instantiate returned NULL\n");
                return 1;
            }
            continue;
        } else if (!strcmp(command, "setup")) {
            s = SetupExperiment(c, 0, 0.0, from_bits(strtok(NULL, " \n")), 0, 0.0);
        } else if (!strcmp(command, "enter")) {
            s = EnterInitializationMode(c);
        } else if (!strcmp(command, "exit")) {
            s = ExitInitializationMode(c);
        } else if (!strcmp(command, "real")) {
            ValueReference vr = (ValueReference)strtoul(strtok(NULL, " \n"), NULL, 10);
            double x = from_bits(strtok(NULL, " \n"));
            s = SetReal(c, &vr, 1, &x);
        } else if (!strcmp(command, "int")) {
            ValueReference vr = (ValueReference)strtoul(strtok(NULL, " \n"), NULL, 10);
            int x = atoi(strtok(NULL, " \n"));
            s = SetInteger(c, &vr, 1, &x);
        } else if (!strcmp(command, "get")) {
            ValueReference vrs[4096];
            double values[4096];
            size_t n = 0;
            char *token;
            while ((token = strtok(NULL, " \n")) && n < 4096) vrs[n++] = (ValueReference)strtoul(token, NULL, 10);
            s = GetReal(c, vrs, n, values);
            fprintf(out, " %d", s);
            for (size_t i = 0; i < n && s <= 1; i++) write_bits(out, values[i]);
            fputc('\n', out);
            continue;
        } else if (!strcmp(command, "step")) {
            double t = from_bits(strtok(NULL, " \n"));
            double h = from_bits(strtok(NULL, " \n"));
            s = DoStep(c, t, h, 0);
            failed = s > 1;
        } else if (!strcmp(command, "save")) {
            State state = NULL;
            s = GetFMUstate(c, &state);
            if (s == 0) s = SerializedFMUstateSize(c, state, &saved_size);
            if (s == 0) {
                free(saved);
                saved = malloc(saved_size);
                s = SerializeFMUstate(c, state, saved, saved_size);
            }
            if (state) FreeFMUstate(c, &state);
            fprintf(out, " %d %zu\n", s, saved_size);
            continue;
        } else if (!strcmp(command, "restore")) {
            State state = NULL;
            s = DeSerializeFMUstate(c, saved, saved_size, &state);
            if (s == 0) s = SetFMUstate(c, state);
            if (state) FreeFMUstate(c, &state);
        } else if (!strcmp(command, "last")) {
            double t = 0.0;
            s = GetRealStatus(c, 2, &t);
            fprintf(out, " %d", s);
            write_bits(out, t);
            fputc('\n', out);
            continue;
        } else if (!strcmp(command, "free")) {
            s = Terminate(c);
            FreeInstance(c);
            c = NULL;
        } else {
            fprintf(stderr, "master: unknown command %s\n", command);
            return 2;
        }
        fprintf(out, " %d\n", s);
    }
    free(saved);
    fclose(out);
    return 0;
}
