#pragma once
/// @file
/// What the AVX-512 kernels of the mapping library share (kernels.h): the target attribute of a
/// kernel function, and a region that silences GCC 12's false -W(maybe-)uninitialized reports
/// inside its own AVX-512 headers (they start some results from _mm512_undefined_*()). Include
/// only from .cc files; every use is inside `#if defined(__x86_64__)`.

#if defined(__x86_64__)
#include <immintrin.h>

/// Compiles a function for AVX-512 F, DQ, VL and BW (kernels::Isa::kAvx512); call it only where
/// kernels::CpuSupports(kernels::Isa::kAvx512).
#define KESTREL_AVX512 gnu::target("avx512f,avx512dq,avx512vl,avx512bw")

/// Opens and closes a region of AVX-512 kernels (file comment).
#define KESTREL_AVX512_BEGIN                                                           \
  _Pragma("GCC diagnostic push") _Pragma("GCC diagnostic ignored \"-Wuninitialized\"") \
      _Pragma("GCC diagnostic ignored \"-Wmaybe-uninitialized\"")
#define KESTREL_AVX512_END _Pragma("GCC diagnostic pop")
#endif
