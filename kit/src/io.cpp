/// \file io.cpp
/// \brief Scene reading with line-precise errors; fast fixed-point output; state digests.
#include "plab/io.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <vector>

#include "plab/errors.hpp"
#include "plab/generate.hpp"

namespace plab {
namespace {

/// The largest N a scene may ask for (beyond it the allocation alone would be a mistake).
constexpr long long kMaxParticles = 100'000'000;

/// A whitespace-separated word and the line it is on.
struct Token {
  std::string_view text;
  long line = 0;
};

/// Splits text into lines and words, remembering line numbers.
class Lexer {
 public:
  Lexer(std::string_view text, std::string file) : text_(text), file_(std::move(file)) {}

  /// The next word, or an empty token at the end of the text.
  Token next() {
    skip_space();
    if (pos_ >= text_.size()) return Token{{}, line_};
    const std::size_t start = pos_;
    while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
    return Token{text_.substr(start, pos_ - start), line_};
  }

  /// The rest of the current line's words after a token (for line-based records).
  std::vector<Token> rest_of_line() {
    std::vector<Token> words;
    while (true) {
      while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\t' ||
                                     text_[pos_] == '\r'))
        ++pos_;
      if (pos_ >= text_.size() || text_[pos_] == '\n') return words;
      const std::size_t start = pos_;
      while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
      words.push_back(Token{text_.substr(start, pos_ - start), line_});
    }
  }

  [[nodiscard]] const std::string& file() const { return file_; }
  /// The line number at the end of the text (for "found end of file").
  [[nodiscard]] long last_line() const { return line_; }

 private:
  static bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }
  void skip_space() {
    while (pos_ < text_.size() && is_space(text_[pos_])) {
      if (text_[pos_] == '\n') ++line_;
      ++pos_;
    }
  }

  std::string_view text_;
  std::string file_;
  std::size_t pos_ = 0;
  long line_ = 1;
};

std::string quoted(std::string_view s) {
  constexpr std::size_t kMax = 40;
  std::string q = "'" + std::string(s.substr(0, kMax)) + (s.size() > kMax ? "...'" : "'");
  return q;
}

std::string found(const Token& t) { return t.text.empty() ? "end of file" : quoted(t.text); }

bool parse_whole(std::string_view s, long long& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && end == s.data() + s.size() && !s.empty();
}

bool parse_real(std::string_view s, double& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), out,
                                         std::chars_format::general);
  return ec == std::errc() && end == s.data() + s.size() && !s.empty() && std::isfinite(out);
}

double expect_real(Lexer& lx, const char* what, Token* where = nullptr) {
  const Token t = lx.next();
  double v = 0;
  if (!parse_real(t.text, v))
    throw InputError(lx.file(), t.text.empty() ? lx.last_line() : t.line, what, found(t));
  if (where) *where = t;
  return v;
}

}  // namespace

Scene parse_scene(std::string_view text, const std::string& file) {
  Lexer lx(text, file);
  Scene s;
  Token t;
  {
    const Token at = lx.next();
    long long n = 0;
    if (!parse_whole(at.text, n) || n <= 0 || n > kMaxParticles)
      throw InputError(file, at.text.empty() ? lx.last_line() : at.line,
                       "the number of particles N (a whole number, 1 to 100000000)", found(at));
    s.particles.resize(static_cast<std::size_t>(n));
  }
  s.box.L = expect_real(lx, "the box side L (a number)", &t);
  const Token l_token = t;
  s.box.r = expect_real(lx, "the radius r (a number)", &t);
  if (!(s.box.r > 0)) throw InputError(file, t.line, "a radius r > 0", found(t));
  if (!(s.box.L > 2 * s.box.r))
    throw InputError(file, l_token.line, "a box side L > 2r = " + std::to_string(2 * s.box.r),
                     found(l_token));
  {
    const Token at = lx.next();
    long long steps = 0;
    if (!parse_whole(at.text, steps) || steps < 0)
      throw InputError(file, at.text.empty() ? lx.last_line() : at.line,
                       "the number of steps S (a whole number >= 0)", found(at));
    s.steps = steps;
  }
  {
    const Token at = lx.next();
    if (at.text == "print") {
      s.mode = Mode::kPrint;
    } else if (at.text == "perf") {
      s.mode = Mode::kPerf;
    } else {
      throw InputError(file, at.text.empty() ? lx.last_line() : at.line,
                       "the mode 'print' or 'perf'", found(at));
    }
  }

  const std::size_t n = s.particles.size();
  std::vector<char> seen(n, 0);
  const double lo = s.box.r;
  const double hi = s.box.L - s.box.r;
  std::size_t count = 0;
  for (Token first = lx.next(); !first.text.empty(); first = lx.next()) {
    std::vector<Token> words{first};
    for (const Token& w : lx.rest_of_line()) words.push_back(w);
    const long line = first.line;
    if (count == n)
      throw InputError(file, line, "end of file after " + std::to_string(n) + " particle lines",
                       found(first));
    if (words.size() != 5)
      throw InputError(file, line, "a particle line 'i x y vx vy' (5 numbers)",
                       std::to_string(words.size()) + (words.size() == 1 ? " word" : " words"));
    long long i = 0;
    if (!parse_whole(words[0].text, i) || i < 0 || i >= static_cast<long long>(n))
      throw InputError(file, line,
                       "a particle index from 0 to " + std::to_string(n - 1), found(words[0]));
    if (seen[i]) throw InputError(file, line, "a particle index not used before", found(words[0]));
    seen[i] = 1;
    double v[4];
    static const char* names[4] = {"x", "y", "vx", "vy"};
    for (int k = 0; k < 4; ++k) {
      if (!parse_real(words[k + 1].text, v[k]))
        throw InputError(file, line, std::string("a finite number for ") + names[k],
                         found(words[k + 1]));
    }
    for (int k = 0; k < 2; ++k) {
      if (!(v[k] >= lo && v[k] <= hi))
        throw InputError(file, line,
                         std::string("a centre ") + names[k] + " inside [r, L-r] = [" +
                             std::to_string(lo) + ", " + std::to_string(hi) + "]",
                         found(words[k + 1]));
    }
    s.particles.x[i] = v[0];
    s.particles.y[i] = v[1];
    s.particles.vx[i] = v[2];
    s.particles.vy[i] = v[3];
    ++count;
  }
  if (count == 0) {
    s.generated = true;
  } else if (count < n) {
    throw InputError(file, lx.last_line(),
                     std::to_string(n) + " particle lines (or none)",
                     "end of file after " + std::to_string(count));
  }
  return s;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Scene load_scene(const std::string& path, std::uint64_t seed) {
  Scene s = parse_scene(read_file(path), path);
  if (s.generated) {
    const std::size_t n = s.particles.size();
    s.particles = generate(s.box, n, seed, default_speeds(s.box));
  }
  return s;
}

std::string format_scene(const Scene& scene) {
  std::string out;
  char buf[64];
  auto real = [&](double v) {
    const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, 17);
    (void)ec;
    out.append(buf, end);
  };
  out += std::to_string(scene.particles.size()) + "\n";
  real(scene.box.L);
  out += "\n";
  real(scene.box.r);
  out += "\n" + std::to_string(scene.steps) + "\n" + mode_name(scene.mode) + "\n";
  const Particles& p = scene.particles;
  for (std::size_t i = 0; i < p.size(); ++i) {
    out += std::to_string(i);
    for (double v : {p.x[i], p.y[i], p.vx[i], p.vy[i]}) {
      out += ' ';
      real(v);
    }
    out += '\n';
  }
  return out;
}

char* format_fixed8(char* out, double v) {
  const auto [end, ec] = std::to_chars(out, out + 400, v, std::chars_format::fixed, 8);
  (void)ec;
  if (*out == '-') {
    bool zero = true;
    for (const char* c = out + 1; c != end; ++c) zero = zero && (*c == '0' || *c == '.');
    if (zero) {
      for (char* c = out; c + 1 != end; ++c) *c = c[1];
      return end - 1;
    }
  }
  return end;
}

void OutputWriter::block(long long step, const Particles& p, bool final) {
  char line[2048];  // %.8f of a double can take up to ~320 characters per field
  const std::size_t n = p.size();
  for (std::size_t i = 0; i < n; ++i) {
    char* c = line;
    c = std::to_chars(c, line + 32, step).ptr;
    *c++ = ' ';
    c = std::to_chars(c, line + 64, i).ptr;
    for (double v : {p.x[i], p.y[i], p.vx[i], p.vy[i]}) {
      *c++ = ' ';
      c = format_fixed8(c, v);
    }
    if (final) {
      *c++ = ' ';
      c = std::to_chars(c, c + 24, p.pc[i]).ptr;
      *c++ = ' ';
      c = std::to_chars(c, c + 24, p.wc[i]).ptr;
    }
    *c++ = '\n';
    buf_.append(line, c);
    if (file_ && buf_.size() > (1u << 20)) flush();
  }
}

void OutputWriter::flush() {
  if (file_ && !buf_.empty()) {
    std::fwrite(buf_.data(), 1, buf_.size(), file_);
    buf_.clear();
  }
}

std::uint64_t digest(const Particles& p) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  auto mix = [&h](std::uint64_t bits) {
    for (int k = 0; k < 8; ++k) {
      h ^= (bits >> (8 * k)) & 0xffu;
      h *= 0x100000001b3ULL;
    }
  };
  auto bits_of = [](double v) {
    std::uint64_t b;
    static_assert(sizeof b == sizeof v);
    __builtin_memcpy(&b, &v, sizeof b);
    return b;
  };
  for (std::size_t i = 0; i < p.size(); ++i) {
    mix(bits_of(p.x[i]));
    mix(bits_of(p.y[i]));
    mix(bits_of(p.vx[i]));
    mix(bits_of(p.vy[i]));
    mix(static_cast<std::uint64_t>(p.pc[i]));
    mix(static_cast<std::uint64_t>(p.wc[i]));
  }
  return h;
}

std::string digest_line(long long step, std::uint64_t hash) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%lld %016llx\n", step, static_cast<unsigned long long>(hash));
  return buf;
}

}  // namespace plab
