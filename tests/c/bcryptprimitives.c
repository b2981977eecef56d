/* A stand-in for Windows' bcryptprimitives.dll, for running Windows binaries under Wine 8.0
 * in the tests alone (tests/python/test_platforms.py puts it beside the test program).
 *
 * Rust's standard library (since 1.78) imports ProcessPrng from bcryptprimitives.dll, which
 * Windows 10 and later have and Wine 8.0 does not: without it the loader refuses the DLL.
 * This forwards to RtlGenRandom (advapi32's SystemFunction036). No FMU ships it.
 */
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
