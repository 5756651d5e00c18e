// Run-time dispatch of the plain C++ hot loops: DOFKIT_CLONES compiles a function for
// AVX-512F, AVX2 and baseline x86-64 and picks one when the program starts (GCC
// target_clones, an ifunc). The Highway kernels (HWY_DYNAMIC_DISPATCH) do not use it.
//
// Every such function in dofkit goes through this macro, never the raw attribute (a test
// scans the sources for that), because of what clang 14 — the compiler of the fuzz build —
// does with it: when the function has an earlier declaration without the attribute (a header
// declaring a function another file calls), clang 14 drops the multiversioning without a
// warning and compiles one body for the first target of the list, AVX-512F. On a machine
// without AVX-512 that body dies of SIGILL as soon as it runs an AVX-512 instruction
// (seen: rgba_row_is_sanitary spilled a zmm register in its prologue and killed the fuzzer
// on every seed; core::any_positive only escaped because the fuzz inputs are too small for
// its vector loop). Under clang the macro is therefore empty: one body for the build's own
// target, which every machine that runs the build can execute.
//
// The clones compute what the baseline body computes, bit for bit: contraction of a multiply
// and an add into one FMA is off in them (GCC's default, -ffp-contract=fast, fuses wherever
// the target has FMA, and AVX-512F implies it: the AVX-512 copies rounded differently from
// the AVX2 and baseline ones, on AVX-512 machines only). Several callers rely on that: the
// strip filters' vertical sweeps must repeat the horizontal passes' sums exactly, and row
// kernels finish their rows with scalar code of the same arithmetic.
#pragma once

#if defined(__clang__)
#define DOFKIT_CLONES
#else
#define DOFKIT_CLONES __attribute__((target_clones("avx512f", "avx2", "default"), optimize("fp-contract=off")))
#endif

// Added to DOFKIT_CLONES where a loop's selects must be if-converted: GCC turns a select into
// a blend (and so vectorises the loop) only without -ftrapping-math, because an ordered
// comparison of a NaN may raise an exception flag — which dofkit never reads, so the option
// changes no result. (clang, the fuzz build: no optimize() attribute; nothing.)
#if defined(__clang__)
#define DOFKIT_NO_TRAPPING_MATH
#else
#define DOFKIT_NO_TRAPPING_MATH __attribute__((optimize("no-trapping-math")))
#endif
