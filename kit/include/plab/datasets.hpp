/// \file datasets.hpp
/// \brief The dataset manifest: every scene, what it tests, and where its golden files are.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "plab/scene.hpp"

namespace plab {

/// How a generated scene is made (the arguments of `plab gen`).
struct GenParams {
  long long n = 0;            //!< particles
  double L = 0;               //!< box side
  double r = 0;               //!< radius
  long long steps = 0;        //!< steps
  Mode mode = Mode::kPrint;   //!< output mode
  std::uint64_t seed = 0;     //!< generator seed
  double speed_min = -1;      //!< speed range (length units per step); negative: model.md's
  double speed_max = -1;      //!< default for the box (L/(8r) .. L/4)
};

/// One scene of the manifest.
struct Dataset {
  std::string name;               //!< file stem: `scenes/NAME.in`, `golden/NAME.out`, `golden/NAME.digest`
  std::string origin;             //!< `course`, `hand` or `generated`
  std::string tests;              //!< what the scene tests, in one sentence
  std::string size;               //!< `small` (every stage), `medium` (stage 02 on), `large` (long runs)
  std::optional<GenParams> gen;   //!< how to regenerate it (generated scenes only)
  long long particles = 0;        //!< N, read from the scene file
};

/// The manifest and the folder it lives in.
struct Manifest {
  std::string root;                //!< the datasets folder
  std::string reference_stage;     //!< the stage whose solution produces the golden files
  std::string exact_stage;         //!< the exact event-driven stage (its own golden files), or ""
  std::vector<Dataset> datasets;   //!< every scene, in manifest order
  [[nodiscard]] std::string scene_path(const Dataset& d) const;   //!< `ROOT/scenes/NAME.in`
  [[nodiscard]] std::string golden_path(const Dataset& d) const;  //!< `ROOT/golden/NAME.out`
  [[nodiscard]] std::string digest_path(const Dataset& d) const;  //!< `ROOT/golden/NAME.digest`
  /// `ROOT/golden/exact/NAME.out`: the exact stage's output (small and medium scenes only)
  [[nodiscard]] std::string exact_golden_path(const Dataset& d) const;
  /// Whether the exact stage has a golden file for this scene (small and medium scenes).
  [[nodiscard]] bool has_exact_golden(const Dataset& d) const {
    return !exact_stage.empty() && d.size != "large";
  }
};

/// Reads `ROOT/manifest.json` (and each scene's N from its file).
/// \throws InputError when the manifest is missing or malformed
Manifest load_manifest(const std::string& root);

/// Makes the scene of a generated dataset (the same bits as `plab gen` with its parameters).
Scene generate_scene(const GenParams& g);

}  // namespace plab
