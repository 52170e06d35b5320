// Included by every kernel file whose float maths must match its scalar reference bit for bit:
// turns floating-point contraction off for the rest of the translation unit, so that a * b + c stays
// a rounded multiply and a rounded add and never becomes one fused multiply-add (which rounds once
// and gives other bits). The kernels library is built with -ffp-contract=off as well
// (src/CMakeLists.txt); this keeps a file right when it is compiled on its own or elsewhere. GCC's
// optimize pragma and clang's fp pragma both hold from here to the end of the including file.
#pragma once

#if defined(__clang__)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif
