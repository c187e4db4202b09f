#pragma once
/// @file
/// For hand-written AVX-512 code outside the mapping kernels (exploration's entropy lanes,
/// exploration/information_gain.cc, taken where kernels::UsesAvx512(kernels::Best())): the
/// target attribute of a function, and a region that silences GCC 12's false
/// -W(maybe-)uninitialized reports inside its own AVX-512 headers (they start some results from
/// _mm512_undefined_*()). The mapping kernels themselves are written once for every instruction
/// set with Highway (kernels.h). Include only from .cc files; every use is inside
/// `#if defined(__x86_64__)`.

#if defined(__x86_64__)
#include <immintrin.h>

/// Compiles a function for AVX-512 F, DQ, VL and BW (Highway's AVX3 target); call it only where
/// kernels::UsesAvx512(kernels::Best()).
#define KESTREL_AVX512 gnu::target("avx512f,avx512dq,avx512vl,avx512bw")

/// Opens and closes a region of AVX-512 kernels (file comment).
#define KESTREL_AVX512_BEGIN                                                           \
  _Pragma("GCC diagnostic push") _Pragma("GCC diagnostic ignored \"-Wuninitialized\"") \
      _Pragma("GCC diagnostic ignored \"-Wmaybe-uninitialized\"")
#define KESTREL_AVX512_END _Pragma("GCC diagnostic pop")
#endif
