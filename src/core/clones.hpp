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
#pragma once

#if defined(__clang__)
#define DOFKIT_CLONES
#else
#define DOFKIT_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#endif
