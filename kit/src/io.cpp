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

/// The largest N a scene may ask for: 48 GB of particles on the host, which the kit's GPU engine
/// runs on one H200 (beyond it the allocation alone would be a mistake, and an int index too small).
constexpr long long kMaxParticles = 1'000'000'000;

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
  std::string q(1, '\'');  // appended piece by piece (GCC 12's -Wrestrict misfires on "'" + ...)
  q.append(s.substr(0, kMax));
  q.append(s.size() > kMax ? "...'" : "'");
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
                       "the number of particles N (a whole number, 1 to 1000000000)", found(at));
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

namespace {

/// The lines of a text, each with its words (split on spaces, tabs and carriage returns).
class Lines {
 public:
  explicit Lines(std::string_view text) : text_(text) {}

  /// Reads the next line into `words`; false at the end of the text.
  bool next(std::vector<std::string_view>& words) {
    if (pos_ >= text_.size()) return false;
    const std::size_t nl = text_.find('\n', pos_);
    const std::string_view row = text_.substr(pos_, nl == std::string_view::npos ? nl : nl - pos_);
    pos_ = nl == std::string_view::npos ? text_.size() : nl + 1;
    ++number_;
    words.clear();
    for (std::size_t i = 0; i < row.size();) {
      while (i < row.size() && (row[i] == ' ' || row[i] == '\t' || row[i] == '\r')) ++i;
      const std::size_t start = i;
      while (i < row.size() && row[i] != ' ' && row[i] != '\t' && row[i] != '\r') ++i;
      if (i > start) words.push_back(row.substr(start, i - start));
    }
    return true;
  }
  /// The number of the line last read (1-based; 0 before the first).
  [[nodiscard]] long number() const { return number_; }

 private:
  std::string_view text_;
  std::size_t pos_ = 0;
  long number_ = 0;
};

std::string word_count(std::size_t n) {
  return n == 0 ? "an empty line" : std::to_string(n) + (n == 1 ? " word" : " words");
}

std::string n_particles(std::size_t n) {
  return std::to_string(n) + (n == 1 ? " particle" : " particles");
}

}  // namespace

std::vector<OutputBlock> parse_output(std::string_view text, const std::string& file) {
  std::vector<OutputBlock> blocks;
  std::size_t n = 0;  // particles per block, known once the first block is complete
  Lines lines(text);
  std::vector<std::string_view> w;
  const auto fail = [&](const std::string& expected, const std::string& what) {
    throw InputError(file, lines.number(), expected, what);
  };
  const auto found_word = [](std::string_view s) { return quoted(s); };
  while (lines.next(w)) {
    if (w.size() != 6 && w.size() != 8)
      fail("a line 'step i x y vx vy' (6 numbers; 8 in the final block, with 'pc wc')",
           word_count(w.size()));
    long long step = 0;
    long long index = 0;
    if (!parse_whole(w[0], step) || step < 0)
      fail("a step (a whole number >= 0)", found_word(w[0]));
    if (!parse_whole(w[1], index) || index < 0)
      fail("a particle index (a whole number >= 0)", found_word(w[1]));
    const bool counters = w.size() == 8;
    if (blocks.empty() || step != blocks.back().step) {
      if (!blocks.empty()) {
        const OutputBlock& last = blocks.back();
        if (last.counters)
          fail("end of file after the final block (step " + std::to_string(last.step) +
                   ", with counters)", "step " + std::string(w[0]));
        if (blocks.size() == 1) n = last.particles.size();
        if (last.particles.size() < n)
          fail("particle " + std::to_string(last.particles.size()) + " of step " +
                   std::to_string(last.step) + " (every block has " + n_particles(n) + ")",
               "step " + std::string(w[0]));
        if (step < last.step)
          fail("a step after " + std::to_string(last.step) + " (blocks in step order)",
               "step " + std::string(w[0]));
      }
      blocks.push_back(OutputBlock{step, counters, {}});
    }
    OutputBlock& b = blocks.back();
    const std::size_t at = b.particles.size();
    if (blocks.size() > 1 && at == n)
      fail("a step after " + std::to_string(step) + " (every block has " + n_particles(n) + ")",
           "a particle " + std::string(w[1]) + " of step " + std::to_string(step));
    if (index != static_cast<long long>(at))
      fail("particle " + std::to_string(at) + " of step " + std::to_string(step) +
               " (particles in index order)", "particle " + std::string(w[1]));
    if (counters != b.counters)
      fail(std::string("a line of ") + (b.counters ? "8" : "6") + " words like the block's first",
           word_count(w.size()));
    double v[4];
    static const char* names[4] = {"x", "y", "vx", "vy"};
    for (int k = 0; k < 4; ++k)
      if (!parse_real(w[k + 2], v[k]))
        fail(std::string("a finite number for ") + names[k], found_word(w[k + 2]));
    long long c[2] = {0, 0};
    for (int k = 0; counters && k < 2; ++k)
      if (!parse_whole(w[k + 6], c[k]) || c[k] < 0)
        fail(std::string("a counter ") + (k == 0 ? "pc" : "wc") + " (a whole number >= 0)",
             found_word(w[k + 6]));
    Particles& p = b.particles;
    p.x.push_back(v[0]);
    p.y.push_back(v[1]);
    p.vx.push_back(v[2]);
    p.vy.push_back(v[3]);
    p.pc.push_back(c[0]);
    p.wc.push_back(c[1]);
  }
  if (blocks.empty()) throw InputError(file, 1, "a line 'step i x y vx vy'", "end of file");
  const OutputBlock& last = blocks.back();
  if (blocks.size() > 1 && last.particles.size() < n)
    throw InputError(file, lines.number(),
                     n_particles(n) + " in step " + std::to_string(last.step),
                     "end of file after " + n_particles(last.particles.size()));
  return blocks;
}

std::vector<EventRecord> parse_events(std::string_view text, const std::string& file) {
  std::vector<EventRecord> events;
  Lines lines(text);
  std::vector<std::string_view> w;
  while (lines.next(w)) {
    const long line = lines.number();
    if (w.size() != 3)
      throw InputError(file, line, "a line 'step i wall|pair' (3 words)", word_count(w.size()));
    EventRecord e;
    if (!parse_whole(w[0], e.step) || e.step < 0)
      throw InputError(file, line, "a step (a whole number >= 0)", quoted(w[0]));
    if (!parse_whole(w[1], e.particle) || e.particle < 0)
      throw InputError(file, line, "a particle index (a whole number >= 0)", quoted(w[1]));
    if (w[2] != "wall" && w[2] != "pair")
      throw InputError(file, line, "the kind 'wall' or 'pair'", quoted(w[2]));
    e.wall = w[2] == "wall";
    if (!events.empty() && e.step < events.back().step)
      throw InputError(file, line,
                       "a step >= " + std::to_string(events.back().step) + " (events in step order)",
                       quoted(w[0]));
    events.push_back(e);
  }
  return events;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Scene load_scene(const std::string& path, std::uint64_t seed,
                 const std::optional<SpeedRange>& speeds) {
  Scene s = parse_scene(read_file(path), path);
  if (s.generated) {
    const std::size_t n = s.particles.size();
    s.particles = Particles();  // the zeros go before the particles come (10^9: 48 GB each)
    s.particles = generate(s.box, n, seed, speeds ? *speeds : default_speeds(s.box));
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
  out += '\n';
  out += std::to_string(scene.steps);
  out += '\n';
  out += mode_name(scene.mode);
  out += '\n';
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
