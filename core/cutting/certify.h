// `mchex-gpu certify`: re-derives the paper's positivity proof (Tong & Zhang 2025, Section 5 and
// its supplementary notebooks) on this code: for every cell type (core/grid/cell_types.h), every one of
// the 24 rotations of its corner labels and every MC33 subcase, the cell is cut as the mesher
// cuts it (core/cutting/polyhedra.h cut_cell, then core/cutting/subdivide.h midpoint_subdivide) with the crossing
// parameters s clamped to [eps, 1 - eps] and taken from corner values drawn at random and at the
// ends (every corner magnitude 1 or 1e-6: all 256 such cells, whose crossings sit at eps or
// 1 - eps), and every one of the 27 Bernstein coefficients of det J of every hex must be > 0.
// Crossings come from corner values because the mesher's do: sampling each s on its own also
// makes combinations that no cell has (and some of those are negative on transition cells).
//
// Every polyhedron goes through core/cutting/repair.h's subdivide_in_cell, as in the mesher: corners mapped
// through the cell's trilinear map, every hex checked, and the volume centre moved by a
// deterministic search where plain midpoint subdivision is not certified (on the transition types:
// case 5, 12.1.1 and case-5 leaves of refined subcases; never on the cube). The table counts those
// polyhedra ("moved centres").
// What the mesher does per subcase decides what is certified ("certify what the mesher will
// actually do"):
//   direct  the paper's 14 templates of Figure 6 plus the uncut cell: cut_cell on the cell itself;
//   local refinement  the subcases core/cutting/local_refinement.h refines (paper Figure 7, the tunnels
//           among them): refine_locally on the cell, then every leaf child classified from its
//           (virtual) values and cut directly, as the mesher does.
// The cell types are those of the vertex-based templates (core/grid/cell_types.h); the children
// of local refinement are covered by refining each type, not listed in the table: refine_locally
// commutes with affine maps (tests/test_certify.cpp LocalRefinementCommutesWithAffineMaps), so the
// leaves of every grid cell are affine images of the leaves certified here.
// What is proven and what is left to run time (docs/templates.md, "Certification"): the cube type
// (every uniform cell, every leaf at max_depth) is proven for every subcase, as in the paper. Most
// transition types are proven for most subcases; for the rest some sampled cell (crossings at the
// clamp ends, on the far from affine cells of the composites) is not certified even after the
// centre search. Those pairs are reported and left to the run-time remedy: every hex is checked as
// it is made, and the pipeline refines the octree leaf of a cell whose polyhedron is not certified
// and meshes again (core/grid/octree.h refine_leaves_of_cells), which ends at cubes. One failure
// decides an entry, so its remaining samples are skipped.
// Repelled cubes (mesh --repel): the same patterns and samples on cubes whose corners grid-point
// repelling moved (each corner along one of its three axes, or not, by up to 0.45 of the edge in
// either direction, drawn with a seed; half of the moved corners at +-0.45), routed and cut as the
// mesher does (a moved cube is not affine: 11 and 14 are refined). What is not certified there is
// handed to the run-time restore (core/cutting/repel.h relax_cells), which ends on the cube.
// Sign patterns: for each subcase, one cell per class of patterns up to rotation and complement
// (the complement gives the same polyhedra), found by classify() on seeded random corner values
// (13.5.2, which random values practically never give, from a constructed cell; a class with few
// samples is widened by a random walk through nearby values of the same class):
// the rotation class of its canonical representative and, for 12.2, the mirror class too (its
// cells map onto the representative only by a reflection).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/cutting/mc33.h"

namespace mchex {

struct CertifyOptions {
  double eps = 1e-3;       // crossings in [eps, 1 - eps], as the mesher's --eps
  int random_samples = 8;  // per (type, rotation, pattern): magnitudes uniform in [0.05, 1]
  int mixed_samples = 8;   // each magnitude 1, 1e-6 or random (plus the 256 end cells)
  std::uint64_t seed = 20250917;
  // Names of the cell types to certify (core/grid/cell_types.h); empty: every type. The single
  // type, which the verdict and the run-time remedy rest on, is always certified.
  std::vector<std::string> types;
  // Repelled cubes (mesh --repel, core/cutting/repel.h): per sign pattern, this many cubes whose
  // corners moved along one of their edges' axes by up to kMaxRepelDelta ...
  int repel_shapes = 48;
  int repel_values = 12;  // ... each cut at this many of the pattern's sampled values
};

enum class CertifyRoute : std::uint8_t { kDirect, kLocalRefinement };
CertifyRoute certify_route(Subcase s);

struct CertifyEntry {             // one (type, subcase)
  std::size_t hexes = 0;          // hexes checked
  std::size_t failed_hexes = 0;   // with a coefficient <= 0
  std::size_t moved_centres = 0;  // polyhedra whose volume centre the search moved (core/cutting/repair.h)
  double min_coefficient = 0;     // min over hexes of min beta / (mean edge)^3 (dimensionless)
  bool checked = false;           // false: needs local refinement (not landed)
};

struct CertifyFailure {
  int type = 0, rotation = 0;
  Subcase subcase = Subcase::kEmpty;
  std::array<double, 12> s{};  // crossing parameters, NaN on uncut edges (Table 1 order)
  double coefficient = 0;      // the hex's min scaled Bernstein coefficient
};

struct CertifyResult {
  CertifyOptions options;
  // [type][subcase]; the rows of types not selected (options.types) stay unchecked
  std::vector<std::array<CertifyEntry, kNumSubcases>> table;
  std::vector<char> selected;  // [type]: certified in this run
  std::optional<CertifyFailure> first_failure;
  std::size_t hexes = 0;
  // (type, rotation, pattern) tasks not cut because an affinely equivalent rotation of the type
  // was cut with the same samples and plain subdivision certified or failed it alike; and cells
  // that a task met twice (the same corners and clamped class) and cut once.
  std::size_t equivalent_tasks = 0;
  std::size_t repeated_cells = 0;
  std::size_t not_landed_subcases = 0;  // subcases no sampled cell reached (not certified)
  // [subcase]: the repelled cubes. Not part of passed(): a repelled cell whose hexes are not
  // certified gets its grid corners back at run time (relax_cells, after halving) and is an unmoved cube,
  // proven above; these entries say how often that remedy can be needed.
  std::array<CertifyEntry, kNumSubcases> repelled{};
  std::size_t repelled_cells = 0;
  double repelled_seconds = 0;
  double seconds = 0;
  // Whether every sampled cell of (type, subcase) was certified.
  bool proven(int type, int subcase) const;
  // Every subcase reached, and the cube type proven for all of them: the run-time remedy
  // (docs/templates.md, "Certification") refines any other cell until it is cubes, so every mesh
  // the pipeline writes is certified. Other pairs may be left to that remedy.
  bool passed() const;
  std::size_t run_time_pairs() const;  // checked (type, subcase) pairs not proven
};

// The type the remedy ends on (core/grid/cell_types.h: the single hex, an affine cube).
inline constexpr int kProvenForEverySubcase = 0;

// Throws InputError for eps outside (0, 0.5) or an unknown type name.
CertifyResult certify(const CertifyOptions& options = {});

// The summary table (subcase rows, type columns), the first failure and the verdict.
std::string certify_report(const CertifyResult& r);

}  // namespace mchex
