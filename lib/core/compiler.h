/* Compiler-specific annotations, each with a portable fallback. */
#ifndef HV_COMPILER_H
#define HV_COMPILER_H

#if defined(__GNUC__) || defined(__clang__)
#define HV_ALWAYS_INLINE __attribute__((always_inline))
#define HV_PREFETCH(address) __builtin_prefetch(address)
#else
#define HV_ALWAYS_INLINE
#define HV_PREFETCH(address) ((void)(address))
#endif

/* Bytes that keep two threads' writes off each other's cache lines (64 on
 * x86-64; the adjacent-line prefetcher pairs lines, and some Arm cores
 * use 128): per-thread state ends with this much padding. A shared line
 * costs a transfer between cores on every write, per photon here. */
#define HV_CACHE_GAP 128

/* The photon loop is compiled twice, for x86-64-v3 (AVX2, BMI: a rounding
 * instruction for floor, wider registers) and for the baseline, and the
 * loader picks one (GNU ifunc). Floating-point contraction stays off in ISO
 * C mode, so both give bitwise the same results. GCC only: clang 14 leaves
 * the dispatcher of a hidden function undefined. */
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__ELF__) && \
    !defined(__SANITIZE_ADDRESS__)
#define HV_TARGET_CLONES_X86_64_V3 __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define HV_TARGET_CLONES_X86_64_V3
#endif

#endif
