#pragma once
// Hot loops compiled twice, for AVX2 and for the baseline x86-64, the loader picking one by the
// CPU it runs on: twice the lanes where the machine has them, one binary for every machine.
// AVX2 alone brings no fused multiply-add, so both clones round every operation alike and give
// the same results bit for bit.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && defined(__linux__)
#define PROJTOUR_VECTOR_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define PROJTOUR_VECTOR_CLONES
#endif
