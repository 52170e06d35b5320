// Helpers for the kernel tests: which variants of a table this CPU (or qemu CPU) can run, and a
// report of what ran and what was skipped, so CI logs show every dispatched path really executed.
#pragma once

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "kernels/variants.h"
#include "platform/cpu/cpu_features.h"

namespace ef::test {

// Tests use the detected features, not the EF_ISA-capped ones: they run every variant the hardware
// can execute, whatever the cap.
template <class Fn, std::size_t N>
std::vector<const kernels::KernelVariant<Fn>*> runnable_variants(const kernels::KernelVariant<Fn> (&table)[N],
                                                                 const char* family) {
  std::vector<const kernels::KernelVariant<Fn>*> out;
  std::string ran, skipped;
  for (const auto& v : table) {
    if (kernels::isa_available(v.isa, detected_cpu_features())) {
      out.push_back(&v);
      ran += std::string(ran.empty() ? "" : " ") + v.name;
    } else {
      skipped += std::string(skipped.empty() ? "" : " ") + v.name + "(no " + kernels::isa_name(v.isa) + ")";
    }
  }
  std::printf("[ variants ] %s: ran %s; skipped %s\n", family, ran.c_str(), skipped.empty() ? "none" : skipped.c_str());
  std::fflush(stdout);
  return out;
}

}  // namespace ef::test
