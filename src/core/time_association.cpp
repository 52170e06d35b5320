#include "core/time_association.h"

#include <algorithm>
#include <cmath>

namespace ef {

std::vector<std::pair<std::size_t, std::size_t>> associate_timestamps(const std::vector<double>& a,
                                                                      const std::vector<double>& b, double max_dt) {
  struct Candidate {
    double dt;
    std::size_t i, j;
  };
  std::vector<Candidate> cands;
  std::size_t j0 = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    while (j0 < b.size() && b[j0] <= a[i] - max_dt) ++j0;
    for (std::size_t j = j0; j < b.size() && b[j] < a[i] + max_dt; ++j) {
      const double dt = std::abs(a[i] - b[j]);
      if (dt < max_dt) cands.push_back(Candidate{dt, i, j});
    }
  }
  std::sort(cands.begin(), cands.end(), [](const Candidate& x, const Candidate& y) {
    if (x.dt != y.dt) return x.dt < y.dt;
    if (x.i != y.i) return x.i < y.i;
    return x.j < y.j;
  });
  std::vector<char> used_a(a.size(), 0), used_b(b.size(), 0);
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (const Candidate& c : cands) {
    if (used_a[c.i] || used_b[c.j]) continue;
    used_a[c.i] = used_b[c.j] = 1;
    out.emplace_back(c.i, c.j);
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace ef
