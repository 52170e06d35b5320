#include "kernels/variants.h"

namespace ef::kernels {

const char* isa_name(Isa isa) {
  switch (isa) {
    case Isa::scalar: return "scalar";
    case Isa::sse41: return "sse41";
    case Isa::avx2: return "avx2";
    case Isa::avxvnni: return "avxvnni";
    case Isa::avx512vnni: return "avx512vnni";
    case Isa::neon: return "neon";
    case Isa::neondot: return "neondot";
  }
  return "?";
}

bool isa_available(Isa isa, const CpuFeatures& f) {
  switch (isa) {
    case Isa::scalar: return true;
    case Isa::sse41: return f.sse41;
    case Isa::avx2: return f.avx2;
    case Isa::avxvnni: return f.avxvnni;
    case Isa::avx512vnni: return f.avx512vnni;
    case Isa::neon: return f.neon;
    case Isa::neondot: return f.neondot;
  }
  return false;
}

}  // namespace ef::kernels
