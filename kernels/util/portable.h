/* Portability layer for code shared by the host (C99/C11) and kernels (OpenCL C 1.2).
 *
 * Rules for every file under kernels/: include this header first; use SPT_FN for
 * functions, SPT_CONSTANT for tables, spt_u32/spt_i32 in structs that cross the
 * host/device boundary; structs hold only 32-bit scalars and fixed arrays, padded by
 * hand, with their size checked on both sides (SPT_STATIC_ASSERT on the host, the
 * layout kernel in tests). No fp64, no images, no OpenCL 2.0. */
#ifndef SPT_PORTABLE_H
#define SPT_PORTABLE_H

#if defined(__OPENCL_VERSION__) || defined(__OPENCL_C_VERSION__)
  #define SPT_DEVICE 1
  #define SPT_FN static inline
  /* A function the compiler must inline (a hot loop's body, whose state then
   * stays in registers). */
  #define SPT_FN_INLINE static inline __attribute__((always_inline))
  #define SPT_CONSTANT __constant
  #define SPT_GLOBAL __global
  typedef uint spt_u32;
  typedef int spt_i32;
  typedef uchar spt_u8;
  typedef ulong spt_u64;
  /* C spellings of the float maths built-ins, so shared code reads the same on
   * both sides. */
  #define sqrtf sqrt
  #define fabsf fabs
  #define fminf fmin
  #define fmaxf fmax
  #define floorf floor
  #define ceilf ceil
  #define expf exp
  #define logf log
  #define powf pow
  #define sinf sin
  #define cosf cos
  #define tanf tan
  #define acosf acos
  #define asinf asin
  #define atan2f atan2
  #define tanhf tanh
  #define coshf cosh
  #define atanhf atanh
  #define copysignf copysign
  #define SPT_STATIC_ASSERT(cond, msg)
  /* For a hot helper LLVM's heuristics leave out of line in a kernel. */
  #define SPT_ALWAYS_INLINE __attribute__((always_inline))
#else
  #include <math.h>
  #include <stdint.h>
  #define SPT_DEVICE 0
  #define SPT_FN static inline
  #define SPT_FN_INLINE static inline __attribute__((always_inline))
  #define SPT_CONSTANT static const
  #define SPT_GLOBAL
  typedef uint32_t spt_u32;
  typedef int32_t spt_i32;
  typedef uint8_t spt_u8;
  typedef uint64_t spt_u64;
  #define SPT_STATIC_ASSERT(cond, msg) _Static_assert(cond, msg)
  #define SPT_ALWAYS_INLINE
#endif

#define SPT_PI 3.14159265358979323846f
#define SPT_INV_PI 0.31830988618379067154f
#define SPT_INV_2PI 0.15915494309189533577f
#define SPT_INV_4PI 0.07957747154594766788f

/* A hint to bring the cache line holding address p closer ahead of its use
 * (__builtin_prefetch; OpenCL's prefetch() does nothing in PoCL). On a CPU device
 * the work-items of a group run one after another, so a work-item can fetch what
 * a later one will read and hide a cache miss behind its own work; its address
 * spaces are one, so a global address passes as a plain one. A no-op on other
 * devices. */
#if SPT_DEVICE && (defined(__x86_64__) || defined(__aarch64__))
  #define SPT_PREFETCH(p) __builtin_prefetch((const void *)(size_t)(p))
#elif !SPT_DEVICE && defined(__GNUC__)
  #define SPT_PREFETCH(p) __builtin_prefetch((const void *)(p))
#else
  #define SPT_PREFETCH(p) ((void)0)
#endif

/* A header that is OpenCL C only (it uses __global pointers, vector types or
 * built-ins with no host spelling) says so with a line holding only
 * SPT_DEVICE_ONLY, after its includes: on the host that line stops the compile
 * with this message. Every other header compiles alone on the host too, which
 * tests/test_kernel_headers.c checks (docs/architecture.md, "Portability
 * rules"). */
#if SPT_DEVICE
  #define SPT_DEVICE_ONLY
#else
  #define SPT_DEVICE_ONLY \
    _Static_assert(0, "an OpenCL C only header (SPT_DEVICE_ONLY) is included on the host");
#endif

/* Wavelengths carried by one path (hero wavelength sampling). */
#define SPT_NUM_LAMBDA 4

#endif
