/// \file io.hpp
/// \brief The kit's one reader and writer of its text formats: scene files, model.md's output
/// and the runner's events file, read with line-precise errors; the output written fast.
/// (Tools in other languages read these formats through `plab read --json`, never themselves.)
#pragma once

#include <cstdint>
#include <cstdio>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "plab/generate.hpp"
#include "plab/scene.hpp"

namespace plab {

/// Reads a scene from `text`; `file` names it in error messages.
/// Particles are left empty (and `generated` set) when the text has no particle lines.
/// \throws InputError `FILE:LINE: expected ..., found ...` for anything model.md rejects
Scene parse_scene(std::string_view text, const std::string& file);

/// Reads a whole file into a string.
/// \throws InputError when the file cannot be read
std::string read_file(const std::string& path);

/// Reads a scene file; generates the particles from `seed` when it has no particle lines, with
/// speeds in `speeds` (model.md's default range when none is given).
/// \throws InputError when the file cannot be read or is malformed
Scene load_scene(const std::string& path, std::uint64_t seed,
                 const std::optional<SpeedRange>& speeds = std::nullopt);

/// Writes a scene file with every particle line (reals with 17 significant digits, so reading
/// it back gives the same bits).
std::string format_scene(const Scene& scene);

/// One block of an output: the state printed for one step.
struct OutputBlock {
  long long step = 0;     //!< the step whose start (or, for the final block, end) it shows
  bool counters = false;  //!< true when its lines end in `pc wc` (the final block of a run)
  Particles particles;    //!< the printed state (`pc`, `wc` zero without counters)
};

/// Reads model.md's output, print or perf mode (and the runner's `--step-from-each` output,
/// whose blocks have no counters). Every line is `step i x y vx vy`, or with ` pc wc` in the last
/// block; a block is the consecutive lines of one step, particles 0 to N-1 in order, the same N in
/// every block, steps increasing; reals are any finite numbers (`-0.00000000` included).
/// \throws InputError `FILE:LINE: expected ..., found ...` for anything else (an empty text too)
std::vector<OutputBlock> parse_output(std::string_view text, const std::string& file);

/// One line of the runner's events file (`--events`): particle `particle` collided in `step`.
struct EventRecord {
  long long step = 0;      //!< the step in which it collided
  long long particle = 0;  //!< its index
  bool wall = false;       //!< with a wall (true) or with another particle (false)
};

/// Reads an events file: lines `STEP INDEX wall|pair`, steps never decreasing (may be empty).
/// \throws InputError `FILE:LINE: expected ..., found ...` for anything else
std::vector<EventRecord> parse_events(std::string_view text, const std::string& file);

/// Formats `v` as `%.8f` in the C locale, writing `-0.00000000` as `0.00000000`.
/// Writes at most 32 characters to `out` and returns the end.
char* format_fixed8(char* out, double v);

/// Appends model.md's output to a buffer and flushes it to a `FILE*` in large writes.
class OutputWriter {
 public:
  /// Writes to `file` (not owned); a null file keeps everything in text().
  explicit OutputWriter(std::FILE* file) : file_(file) {}
  ~OutputWriter() = default;  // unflushed text is dropped: a failed run prints no partial block
  OutputWriter(const OutputWriter&) = delete;
  OutputWriter& operator=(const OutputWriter&) = delete;

  /// Appends the block of lines `step i x y vx vy` (with ` pc wc` when `final`).
  void block(long long step, const Particles& p, bool final);
  /// Writes what is buffered to the file (if any).
  void flush();
  /// What was written so far when there is no file.
  [[nodiscard]] const std::string& text() const { return buf_; }

 private:
  std::FILE* file_;
  std::string buf_;
};

/// A 64-bit FNV-1a hash of the bits of every field of every particle.
std::uint64_t digest(const Particles& p);

/// Formats a digest line: `step hhhhhhhhhhhhhhhh` (16 hex digits).
std::string digest_line(long long step, std::uint64_t hash);

}  // namespace plab
