/* A stand-in for Windows' bcryptprimitives.dll, for testing the win64 binaries under wine.
 *
 * Why: Rust's standard library for Windows imports ProcessPrng from bcryptprimitives.dll
 * (present since Windows 10) for its random hash-map keys. Wine 8, Debian's, has no such
 * export, so without this the FMU's DLL does not load under wine at all. It is placed
 * beside the master and preferred to wine's own (WINEDLLOVERRIDES=bcryptprimitives=n,b);
 * it fills the buffer from RtlGenRandom (advapi32's SystemFunction036), which wine has.
 * Nothing the FMUs compute depends on these bytes. Never shipped in an FMU. */

#include <windows.h>

BOOLEAN WINAPI SystemFunction036(PVOID buffer, ULONG length);

__declspec(dllexport) BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T length) {
    while (length > 0) {
        ULONG chunk = length > 0x10000000 ? 0x10000000 : (ULONG)length;
        if (!SystemFunction036(data, chunk)) return FALSE;
        data += chunk;
        length -= chunk;
    }
    return TRUE;
}
