/* Core clock probe: times a chain of dependent integer adds (one cycle of latency each on
 * every x86 core of the last decade), so adds per second = the core's clock while it runs.
 * Run it alone and next to a load on the other core to see whether that load lowers the
 * clock (AVX-512 licences, power limits, a shared physical core under a hypervisor).
 * Build: gcc -O2 clock.c -o clock.   Usage: clock [SECONDS]   Prints: ghz=G seconds=S */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

int main(int argc, char **argv) {
    double want = argc > 1 ? atof(argv[1]) : 1.0;
    unsigned long x = 0, adds = 0, one = (unsigned long)(argc > 0);
    double start = now(), t = 0.0;
    do {
        for (int i = 0; i < 100000; i++) {
            /* 64 dependent register adds per pass (register, not immediate, operands: some
             * cores fold chains of add-immediate in the renamer); the loop's own counter
             * runs beside the chain. */
            __asm__ volatile(".rept 64\n\tadd %1, %0\n\t.endr" : "+r"(x) : "r"(one));
        }
        adds += 6400000UL;
        t = now() - start;
    } while (t < want);
    printf("ghz=%.4f seconds=%.3f check=%lu\n", (double)adds / t / 1e9, t, x == adds ? 1UL : 0UL);
    return x == adds ? 0 : 1;
}
