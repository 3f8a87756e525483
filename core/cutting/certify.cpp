#include "core/cutting/certify.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <string_view>
#include <unordered_set>

#include <fmt/format.h>

#include "core/base/error.h"
#include "core/base/parallel.h"
#include "core/cutting/local_refinement.h"
#include "core/cutting/polyhedra.h"
#include "core/cutting/repair.h"
#include "core/cutting/repel.h"
#include "core/cutting/subdivide.h"
#include "core/grid/cell_types.h"
#include "core/mesh/quality.h"

namespace mchex {

CertifyRoute certify_route(Subcase s) {
  // The local-refinement module's own routing (core/cutting/local_refinement.h, paper Figure 7).
  return needs_local_refinement(s) ? CertifyRoute::kLocalRefinement : CertifyRoute::kDirect;
}

namespace {

struct Pattern {
  Subcase subcase;
  CellClass cls;
  std::array<double, 8> f;  // the cell it was found on
};

// Cells of the subcases that seeded random draws practically never give: 13.5.2 needs both of the
// cell's body saddles inside it with the tunnel's sign (core/cutting/mc33.h's interior test). The values
// are tests/test_mc33.cpp's 13.5.2 example; samples() walks from it through nearby cells of the
// same class.
constexpr std::array<std::array<double, 8>, 1> kConstructedCells = {{
    {1.0, -0.2, 1.0, -0.8, -0.3, 0.4, -0.3, 0.2},
}};

// One classified cell per direct subcase and class of sign patterns up to rotation (the
// representative's own class, and the mirror class where the subcase needs a reflection).
std::vector<Pattern> patterns(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.05, 1.0);
  std::bernoulli_distribution coin(0.5);
  std::array<std::array<bool, 2>, kNumSubcases> seen{};
  std::vector<Pattern> out;
  for (int draw = 0; draw < 64; ++draw)
    for (int mask = 0; mask < 256; ++mask) {
      std::array<double, 8> f;
      for (int c = 0; c < 8; ++c) {
        const double m = draw % 2 ? (coin(rng) ? 1.0 : 1e-3 * u(rng)) : u(rng);
        f[c] = (mask >> c & 1) ? m : -m;
      }
      const CellClass c = classify(f);
      const int mirror = c.symmetry >= kNumCubeRotations;
      if (seen[static_cast<int>(c.subcase)][mirror]) continue;
      seen[static_cast<int>(c.subcase)][mirror] = true;
      out.push_back({c.subcase, c, f});
    }
  for (const auto& f : kConstructedCells) {
    const CellClass c = classify(f);
    const int mirror = c.symmetry >= kNumCubeRotations;
    if (seen[static_cast<int>(c.subcase)][mirror]) continue;
    seen[static_cast<int>(c.subcase)][mirror] = true;
    out.push_back({c.subcase, c, f});
  }
  std::sort(out.begin(), out.end(), [](const Pattern& a, const Pattern& b) {
    return std::make_pair(a.subcase, a.cls.symmetry >= kNumCubeRotations) <
           std::make_pair(b.subcase, b.cls.symmetry >= kNumCubeRotations);
  });
  return out;
}

// What a cell's cut and its certificate depend on: the cell's corners and its clamped class (the
// sign pattern, the face and interior outcomes and the crossings; the regions follow from those).
// Different sampled values often give the same leaf cells (crossings clamped to eps or 1 - eps,
// the same corner magnitudes behind a refined cell's inner points), whose hexes are the same.
// Compared and hashed as its bytes (no padding), in place: no string per cell.
struct CutKey {
  HexCorners cell;
  std::array<double, 12> crossing;
  std::array<std::uint8_t, 8> tail;
};
static_assert(sizeof(CutKey) == sizeof(HexCorners) + sizeof(double) * 12 + 8);

CutKey cut_key(const HexCorners& cell, const CellClass& c) {
  return {cell,
          c.crossing,
          {c.sign_mask, static_cast<std::uint8_t>(c.subcase), c.face_joins, static_cast<std::uint8_t>(c.tunnel),
           c.symmetry, static_cast<std::uint8_t>(c.inverted), static_cast<std::uint8_t>(c.cut_edges & 0xFF),
           static_cast<std::uint8_t>(c.cut_edges >> 8)}};
}

// Byte equality (a NaN crossing equals itself, as it should) and a hash of the bytes.
struct CutKeyBytes {
  bool operator()(const CutKey& a, const CutKey& b) const { return std::memcmp(&a, &b, sizeof(CutKey)) == 0; }
  std::size_t operator()(const CutKey& k) const {
    return std::hash<std::string_view>()(std::string_view(reinterpret_cast<const char*>(&k), sizeof(CutKey)));
  }
};

struct TaskResult {
  std::size_t hexes = 0, failed = 0, moved_centres = 0;
  std::size_t repeated_cells = 0;  // cells cut before in this task (same corners and class): skipped
  double min_coefficient = std::numeric_limits<double>::infinity();
  std::optional<CertifyFailure> failure;
  std::unordered_set<CutKey, CutKeyBytes, CutKeyBytes> cut;  // every cell cut so far in this task
  // Scratch for each cell's polyhedra and their hexes, reused by the task's cells.
  std::vector<Polyhedron> polys;
  MappedSubdivision mapped;
};

// The cells of one pattern to cut: corner values with the pattern's signs and magnitudes drawn
// at random, at the ends (every corner at 1 or at 1e-6, which puts the crossings at the clamp
// eps or 1 - eps) and mixed, each classified and clamped as the mesher does; draws whose face or
// interior tests change the subcase's topology are skipped. Crossings come from corner values,
// so only combinations a cell can have are certified (sampling each s on its own also gives
// combinations no corner values make, and some of those are negative on transition cells).
struct Sample {
  std::array<double, 8> f;
  CellClass cls;
};

// Crossings clamped to [eps, 1 - eps], as the mesher does.
CellClass clamped(CellClass c, double eps) {
  clamp_crossings(c, eps);
  return c;
}

constexpr std::size_t kWalkBelow = 16;   // a class with fewer samples than this is walked ...
constexpr std::size_t kWalkTarget = 32;  // ... until it has this many (or kWalkSteps steps)
constexpr int kWalkSteps = 256;

std::vector<Sample> samples(const Pattern& p, const CertifyOptions& o, std::mt19937_64& rng) {
  const CellClass& ref = p.cls;
  std::uniform_real_distribution<double> u(0.05, 1.0);
  std::bernoulli_distribution coin(0.5);
  std::vector<Sample> out;
  auto add = [&](const std::array<double, 8>& magnitude) {
    std::array<double, 8> f;
    for (int c = 0; c < 8; ++c) f[c] = (ref.sign_mask >> c & 1) ? magnitude[c] : -magnitude[c];
    const CellClass c = classify(f);
    if (c.subcase != ref.subcase || c.face_joins != ref.face_joins || c.tunnel != ref.tunnel) return;
    out.push_back({f, c});
  };
  if (ref.cut_edges == 0) {
    add({1, 1, 1, 1, 1, 1, 1, 1});
    return out;
  }
  for (int i = 0; i < o.random_samples; ++i) {
    std::array<double, 8> m;
    for (double& x : m) x = u(rng);
    add(m);
  }
  for (int bits = 0; bits < 256; ++bits) {
    std::array<double, 8> m;
    for (int c = 0; c < 8; ++c) m[c] = (bits >> c & 1) ? 1.0 : 1e-6;
    add(m);
  }
  for (int i = 0; i < o.mixed_samples; ++i) {
    std::array<double, 8> m;
    for (double& x : m) x = coin(rng) ? (coin(rng) ? 1.0 : 1e-6) : u(rng);
    add(m);
  }
  // A class that the draws above rarely reach (13.5.2 above all): a random walk from the pattern's
  // own cell, each step scaling every corner magnitude by a factor in [e^-1, e], kept in
  // [1e-6, 1] and accepted only when the class stays, so the samples spread over the class's
  // region of values instead of sitting on one cell.
  if (out.size() < kWalkBelow) {
    std::normal_distribution<double> n01(0, 1);
    std::array<double, 8> m;
    for (int c = 0; c < 8; ++c) m[c] = std::abs(p.f[c]);
    const double top = *std::max_element(m.begin(), m.end());
    for (double& x : m) x /= top;
    for (int step = 0; step < kWalkSteps && out.size() < kWalkTarget; ++step) {
      std::array<double, 8> trial = m;
      for (double& x : trial) x = std::clamp(x * std::exp(std::clamp(n01(rng), -1.0, 1.0)), 1e-6, 1.0);
      const std::size_t before = out.size();
      add(trial);
      if (out.size() > before) m = trial;
    }
  }
  // Many end cells clamp to the same crossings (the cut does not depend on the values beyond its
  // class and crossings, except through the inner points' virtual values of a refined cell):
  // keep one per distinct (crossings, values' signs pattern) for direct cells.
  if (!needs_local_refinement(ref)) {
    auto key = [&](const Sample& a) { return clamped(a.cls, o.eps).crossing; };
    std::vector<Sample> unique;
    std::vector<std::array<double, 12>> seen;
    for (const Sample& smp : out) {
      const auto k = key(smp);
      bool dup = false;
      for (const auto& q : seen) dup = dup || std::memcmp(q.data(), k.data(), sizeof(k)) == 0;
      if (dup) continue;
      seen.push_back(k);
      unique.push_back(smp);
    }
    out.swap(unique);
  }
  return out;
}

// One cell of class c cut as the mesher builds its hexes (in the parametric cube, corners mapped
// by the cell's map), each hex's certificate counted into tr; the first failure is `where` with
// its coefficient.
void cut_and_check(const HexCorners& cell, const CellClass& c, CertifyFailure where, TaskResult& tr) {
  if (!tr.cut.insert(cut_key(cell, c)).second) {
    ++tr.repeated_cells;
    return;
  }
  MappedSubdivision& ms = tr.mapped;
  cut_cell(kUnitCubeCorners, c, tr.polys);
  for (const Polyhedron& poly : tr.polys) {
    subdivide_in_cell(poly, cell, ms);
    tr.moved_centres += ms.centre_moved;
    for (const double scaled : ms.hex_min_scaled) {
      ++tr.hexes;
      tr.min_coefficient = std::min(tr.min_coefficient, scaled);
      if (!(scaled > 0)) {
        ++tr.failed;
        if (!tr.failure) {
          where.coefficient = scaled;
          tr.failure = where;
        }
      }
    }
  }
}

// One task's hexes counted into its (type, subcase) entry.
void add_task(CertifyEntry& e, const TaskResult& tr) {
  e.min_coefficient = e.checked ? std::min(e.min_coefficient, tr.min_coefficient) : tr.min_coefficient;
  e.checked = true;
  e.hexes += tr.hexes;
  e.failed_hexes += tr.failed;
  e.moved_centres += tr.moved_centres;
}

// One sample cut as the mesher routes it: whole, or (where local refinement applies) as the 7
// children (and a second level where the template asks) with virtual values at the inner points,
// each leaf classified and cut on its own. check(cell corners, class, the parent's crossings).
template <class Check>
void route_as_the_mesher(const HexCorners& corners, const Sample& smp, double eps, const Check& check) {
  const CellClass c = clamped(smp.cls, eps);
  if (!needs_local_refinement(smp.cls, corners)) {
    check(corners, c, c.crossing);
    return;
  }
  const LocalRefinement lr = refine_locally(corners, smp.f, smp.cls, 1e-10);
  for (std::size_t i = 0; i < lr.cells.size(); ++i) {
    const LocalRefinementLeaf leaf = leaf_cell(lr, i);
    check(leaf.corners, clamped(classify(leaf.values), eps), c.crossing);
  }
}

// A cube whose corners repel moved: each along one axis or not, by up to kMaxRepelDelta of the
// edge either way (the extremes half the time, where the cells are farthest from the cube).
HexCorners repelled_cube(std::mt19937_64& rng) {
  std::uniform_int_distribution<int> axis(-1, 2);
  std::uniform_real_distribution<double> amount(-kMaxRepelDelta, kMaxRepelDelta);
  std::bernoulli_distribution coin(0.5);
  HexCorners c = kUnitCubeCorners;
  for (Vec3& x : c) {
    const int a = axis(rng);
    if (a < 0) continue;
    const double m = coin(rng) ? (coin(rng) ? kMaxRepelDelta : -kMaxRepelDelta) : amount(rng);
    (a == 0 ? x.x : a == 1 ? x.y : x.z) += m;
  }
  return c;
}

// The repelled cubes' entries (certify.h): every pattern on options.repel_shapes cubes, each at
// options.repel_values of its samples, routed as the mesher routes them.
void certify_repelled(const std::vector<Pattern>& pats, const CertifyOptions& o, CertifyResult& r) {
  const auto start = std::chrono::steady_clock::now();
  const std::size_t shapes = static_cast<std::size_t>(std::max(0, o.repel_shapes));
  std::vector<TaskResult> results(pats.size() * shapes);
  std::vector<std::size_t> cells(results.size());
  parallel_chunks(results.size(), 1, [&](std::size_t begin, std::size_t end) {
    for (std::size_t task = begin; task < end; ++task) {
      const Pattern& p = pats[task / shapes];
      std::mt19937_64 rng(o.seed ^ (0xD1B54A32D192ED03ULL * (task + 1)));
      const HexCorners corners = repelled_cube(rng);
      TaskResult& tr = results[task];
      auto check = [&](const HexCorners& cell, const CellClass& c, const std::array<double, 12>& s) {
        cut_and_check(cell, c, {kProvenForEverySubcase, 0, p.subcase, s, 0}, tr);
      };
      const std::vector<Sample> all = samples(p, o, rng);
      const std::size_t want = static_cast<std::size_t>(std::max(1, o.repel_values));
      const std::size_t stride = std::max<std::size_t>(1, all.size() / want);
      for (std::size_t i = 0; i < all.size() && !tr.failed; i += stride) {
        const Sample& smp = all[i];
        ++cells[task];
        route_as_the_mesher(corners, smp, o.eps, check);
      }
      tr.cut = {};
      tr.polys = {};
      tr.mapped = {};
    }
  });
  for (std::size_t task = 0; task < results.size(); ++task) {
    CertifyEntry& e = r.repelled[static_cast<int>(pats[task / shapes].subcase)];
    const TaskResult& tr = results[task];
    add_task(e, tr);
    r.repelled_cells += cells[task];
  }
  r.repelled_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

CertifyResult certify(const CertifyOptions& o) {
  if (!(o.eps > 0 && o.eps < 0.5)) throw InputError(fmt::format("--eps must be in (0, 0.5), got {}", o.eps));
  const auto start = std::chrono::steady_clock::now();
  const auto types = cell_types();
  CertifyResult r;
  r.options = o;
  r.table.assign(types.size(), {});
  r.selected.assign(types.size(), o.types.empty());
  r.selected[kProvenForEverySubcase] = 1;
  for (const std::string& name : o.types) {
    std::size_t t = 0;
    while (t < types.size() && types[t].name != name) ++t;
    if (t == types.size()) {
      std::string known;
      for (const CellType& ct : types) known += fmt::format("{}{}", known.empty() ? "" : ", ", ct.name);
      throw InputError(fmt::format("unknown cell type '{}' (the types: {})", name, known));
    }
    r.selected[t] = 1;
  }
  const std::vector<Pattern> pats = patterns(o.seed);
  const std::size_t per_pattern = types.size() * kNumCubeRotations;
  // Rotations of a type whose moved corners are affine images of an earlier rotation's (the cube's
  // 24 are one class; the 1200 (type, rotation) pairs form 787 classes) give the same verdict for
  // the same corner values under plain subdivision: the cut in the parametric cube is the same, and
  // det J of the image hexes is det A > 0 times the original's. So each class is cut once, on its
  // first rotation, with the samples drawn for every rotation of the class (the 256 end cells,
  // the same for all, then cut once). The centre search is not affine invariant (it works in
  // lengths), so where a class's cut moved a centre each rotation is cut on its own as well.
  std::vector<std::array<int, kNumCubeRotations>> rep(types.size());
  for (std::size_t t = 0; t < types.size(); ++t)
    for (int q = 0; q < kNumCubeRotations; ++q) {
      rep[t][q] = q;
      const HexCorners mine = transform_hex(types[t].corners, q);
      for (int e = 0; e < q && rep[t][q] == q; ++e)
        if (rep[t][e] == e && affinely_equivalent(transform_hex(types[t].corners, e), mine)) rep[t][q] = e;
    }
  std::vector<TaskResult> results(pats.size() * per_pattern);
  std::vector<char> ran(results.size(), 0);
  // A task is (pattern, type, rotation), rotation fastest.
  auto type_of = [&](std::size_t task) { return static_cast<int>(task % per_pattern / kNumCubeRotations); };
  auto rotation_of = [](std::size_t task) { return static_cast<int>(task % kNumCubeRotations); };
  // Cuts each task's cell (its type moved by its rotation) at the samples drawn for every rotation
  // of its class (whole_class) or for its own rotation alone.
  auto run = [&](const std::vector<std::size_t>& tasks, bool whole_class) {
    parallel_chunks(tasks.size(), 1, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        const std::size_t task = tasks[i];
        const Pattern& p = pats[task / per_pattern];
        const int type = type_of(task), rotation = rotation_of(task);
        const HexCorners corners = transform_hex(types[type].corners, rotation);
        TaskResult& tr = results[task];
        auto check = [&](const HexCorners& cell, const CellClass& c, const std::array<double, 12>& s) {
          cut_and_check(cell, c, {type, rotation, p.subcase, s, 0}, tr);
        };
        for (int q = 0; q < kNumCubeRotations && !tr.failed; ++q) {
          if (whole_class ? rep[type][q] != rotation : q != rotation) continue;
          const std::size_t drawn = task - static_cast<std::size_t>(rotation) + static_cast<std::size_t>(q);
          std::mt19937_64 rng(o.seed ^ (0x9E3779B97F4A7C15ULL * (drawn + 1)));
          for (const Sample& smp : samples(p, o, rng)) {
            // One failure decides the entry (its cells go to the run-time remedy); the rest of its
            // samples would only count more.
            if (tr.failed) break;
            route_as_the_mesher(corners, smp, o.eps, check);
          }
        }
        tr.cut = {};  // the task's keys are done with; they would hold gigabytes to the end
        tr.polys = {};
        tr.mapped = {};
        ran[task] = 1;
      }
    });
  };
  std::vector<std::size_t> first, second;
  for (std::size_t task = 0; task < results.size(); ++task) {
    const int type = type_of(task), rotation = rotation_of(task);
    if (r.selected[type] && rep[type][rotation] == rotation) first.push_back(task);
  }
  run(first, true);
  for (std::size_t task = 0; task < results.size(); ++task) {
    const int type = type_of(task), rotation = rotation_of(task);
    if (ran[task] || !r.selected[type]) continue;
    const TaskResult& by = results[task - static_cast<std::size_t>(rotation - rep[type][rotation])];
    if (by.moved_centres > 0 && !by.failed) second.push_back(task);
    else ++r.equivalent_tasks;
  }
  run(second, false);
  for (std::size_t task = 0; task < results.size(); ++task) {
    if (!ran[task]) continue;
    const Pattern& p = pats[task / per_pattern];
    CertifyEntry& e = r.table[type_of(task)][static_cast<int>(p.subcase)];
    const TaskResult& tr = results[task];
    add_task(e, tr);
    r.hexes += tr.hexes;
    r.repeated_cells += tr.repeated_cells;
    if (tr.failure && !r.first_failure) r.first_failure = tr.failure;
  }
  certify_repelled(pats, o, r);
  // Every subcase must have been reached by the pattern search, else it is not certified.
  for (int s = 0; s < kNumSubcases; ++s) {
    bool checked = false;
    for (const auto& row : r.table) checked = checked || row[s].checked;
    r.not_landed_subcases += !checked;
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

bool CertifyResult::proven(int type, int subcase) const {
  const CertifyEntry& e = table.at(static_cast<std::size_t>(type))[subcase];
  return e.checked && e.failed_hexes == 0;
}

bool CertifyResult::passed() const {
  if (not_landed_subcases != 0 || table.empty()) return false;
  for (int s = 0; s < kNumSubcases; ++s)
    if (!proven(kProvenForEverySubcase, s)) return false;
  return true;
}

std::size_t CertifyResult::run_time_pairs() const {
  std::size_t n = 0;
  for (std::size_t t = 0; t < table.size(); ++t)
    for (int s = 0; s < kNumSubcases; ++s) n += table[t][s].checked && !proven(static_cast<int>(t), s);
  return n;
}

std::string certify_report(const CertifyResult& r) {
  const auto types = cell_types();
  const auto chosen = static_cast<std::size_t>(std::count(r.selected.begin(), r.selected.end(), 1));
  std::string out =
      fmt::format("certify: {} cell types{} x {} rotations x {} subcases, crossings in [{}, {}]; the 27 Bernstein "
                  "coefficients of det J of every hex must be > 0\n",
                  chosen, chosen == types.size() ? "" : fmt::format(" (of {})", types.size()), kNumCubeRotations,
                  kNumSubcases - 1, r.options.eps, 1 - r.options.eps);
  out += "(local-refinement subcases through refine_locally on each type: its children are covered too)\n";
  // Per type: how many subcases are proven, the least coefficient over them, and the subcases left
  // to the run-time remedy.
  out += fmt::format("{:<18} {:>10} {:>7} {:>9} {:>7}  {}\n", "type", "hexes", "proven", "min coef", "moved",
                     "left to the run-time remedy");
  for (std::size_t t = 0; t < types.size(); ++t) {
    if (!r.selected.at(t)) continue;
    std::size_t hexes = 0, moved = 0;
    int proven = 0;
    double least = std::numeric_limits<double>::infinity();
    std::string left;
    for (int s = 0; s < kNumSubcases; ++s) {
      const CertifyEntry& e = r.table[t][s];
      if (!e.checked) continue;
      hexes += e.hexes;
      moved += e.moved_centres;
      if (r.proven(static_cast<int>(t), s)) {
        ++proven;
        least = std::min(least, e.min_coefficient);
      } else {
        left += fmt::format(" {}", std::string(subcase_name(static_cast<Subcase>(s))));
      }
    }
    out += fmt::format("{:<18} {:>10} {:>4}/{:<2} {:>9.1e} {:>7} {}\n", types[t].name, hexes, proven, kNumSubcases,
                       least, moved, left.empty() ? " -" : left);
  }
  out += "(min coef: least over the proven subcases' hexes of min coefficient / mean edge^3; moved: polyhedra whose\n"
         "volume centre the search of core/cutting/repair.h moved because plain subdivision was not certified)\n";
  for (int s = 0; s < kNumSubcases; ++s) {
    bool checked = false;
    for (std::size_t t = 0; t < types.size(); ++t) checked = checked || r.table[t][s].checked;
    if (!checked)
      out += fmt::format("subcase {} NOT CHECKED (no cell of this subcase found)\n",
                         std::string(subcase_name(static_cast<Subcase>(s))));
  }
  if (r.first_failure) {
    const CertifyFailure& f = *r.first_failure;
    std::string s;
    for (int e = 0; e < 12; ++e)
      if (!std::isnan(f.s[e])) s += fmt::format(" s{}={:.6g}", e + 1, f.s[e]);
    out += fmt::format("first unproven cell: type {} rotation {} subcase {}:{} (coefficient {:.3e})\n",
                       types[f.type].name, f.rotation, std::string(subcase_name(f.subcase)), s, f.coefficient);
  }
  {
    // The repelled cubes (mesh --repel): what relax_cells may be asked to take back.
    int proven = 0, checked = 0;
    std::size_t hexes = 0;
    double least = std::numeric_limits<double>::infinity();
    std::string left;
    for (int s = 0; s < kNumSubcases; ++s) {
      const CertifyEntry& e = r.repelled[s];
      if (!e.checked) continue;
      ++checked;
      hexes += e.hexes;
      if (e.failed_hexes == 0) {
        ++proven;
        least = std::min(least, e.min_coefficient);
      } else {
        left += fmt::format(" {}", std::string(subcase_name(static_cast<Subcase>(s))));
      }
    }
    out += fmt::format(
        "repelled cubes (mesh --repel; corners moved along their edges by up to {}): {} cells, {} hexes, {}/{} "
        "subcases certified on every sample (min coef {:.1e}) in {:.1f} s; left to the run-time remedy "
        "(relax_cells: the cell's corner moves halved, then undone, ending on a proven cube):{}\n",
        kMaxRepelDelta, r.repelled_cells, hexes, proven, checked, least, r.repelled_seconds,
        left.empty() ? " -" : left);
  }
  const std::size_t left = r.run_time_pairs();
  out += fmt::format("{} (type, rotation, pattern) cuts decided by an affinely equivalent rotation's; {} cells "
                     "cut twice in one of them skipped\n",
                     r.equivalent_tasks, r.repeated_cells);
  out += fmt::format("{} hexes checked in {:.1f} s; {} subcases not checked; {} of {} (type, subcase) pairs proven\n",
                     r.hexes, r.seconds, r.not_landed_subcases, chosen * kNumSubcases - left, chosen * kNumSubcases);
  if (r.passed())
    out += left == 0 ? "certify: PASSED\n"
                     : fmt::format("certify: PASSED: the {} type proven for every subcase; {} transition-type pairs "
                                   "left to the run-time remedy (every hex is checked as it is made, and a cell "
                                   "not certified has its octree leaf refined, down to {} cells)\n",
                                   types[kProvenForEverySubcase].name, left, types[kProvenForEverySubcase].name);
  else
    out += fmt::format("certify: NOT PASSED ({})\n",
                       r.not_landed_subcases ? "a subcase was not checked"
                                             : "the cube type, which the run-time remedy ends on, is not proven");
  return out;
}

}  // namespace mchex
