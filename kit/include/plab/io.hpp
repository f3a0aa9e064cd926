/// \file io.hpp
/// \brief Reading scene files (with precise errors) and writing model.md's output fast.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>

#include "plab/scene.hpp"

namespace plab {

/// Reads a scene from `text`; `file` names it in error messages.
/// Particles are left empty (and `generated` set) when the text has no particle lines.
/// \throws InputError `FILE:LINE: expected ..., found ...` for anything model.md rejects
Scene parse_scene(std::string_view text, const std::string& file);

/// Reads a whole file into a string.
/// \throws InputError when the file cannot be read
std::string read_file(const std::string& path);

/// Reads a scene file; generates the particles from `seed` when it has no particle lines.
/// \throws InputError when the file cannot be read or is malformed
Scene load_scene(const std::string& path, std::uint64_t seed);

/// Writes a scene file with every particle line (reals with 17 significant digits, so reading
/// it back gives the same bits).
std::string format_scene(const Scene& scene);

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
