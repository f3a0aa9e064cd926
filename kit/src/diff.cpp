/// \file diff.cpp
/// \brief Line-by-line comparison of outputs, naming the first differing field.
#include "plab/diff.hpp"

#include <charconv>
#include <map>
#include <sstream>
#include <vector>


namespace plab {
namespace {

std::vector<std::string_view> split_lines(std::string_view s) {
  std::vector<std::string_view> lines;
  while (!s.empty()) {
    const std::size_t nl = s.find('\n');
    lines.push_back(s.substr(0, nl));
    if (nl == std::string_view::npos) break;
    s.remove_prefix(nl + 1);
  }
  return lines;
}

std::vector<std::string_view> split_words(std::string_view s) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && (s[i] == ' ' || s[i] == '\t' || s[i] == '\r')) ++i;
    const std::size_t start = i;
    while (i < s.size() && s[i] != ' ' && s[i] != '\t' && s[i] != '\r') ++i;
    if (i > start) words.push_back(s.substr(start, i - start));
  }
  return words;
}

const char* field_name(std::size_t k, std::size_t count) {
  if (count == 2) return k == 0 ? "step" : "digest";
  static const char* names[] = {"step", "particle", "x", "y", "vx", "vy", "pc", "wc"};
  return k < 8 ? names[k] : "extra field";
}

using StepLines = std::map<long long, std::vector<std::vector<std::string_view>>>;

/// The lines of each step (see compare_steps()), and the steps in order of first appearance.
StepLines lines_by_step(std::string_view text, std::vector<long long>* order) {
  StepLines steps;
  for (const std::string_view line : split_lines(text)) {
    auto words = split_words(line);
    if (words.size() < 6) continue;
    std::string_view first = words[0];
    if (first.size() > 1 && first.front() == '+') first.remove_prefix(1);
    long long step = 0;
    const auto [end, ec] = std::from_chars(first.data(), first.data() + first.size(), step);
    if (ec != std::errc() || end != first.data() + first.size()) continue;
    auto [at, fresh] = steps.try_emplace(step);
    if (fresh && order) order->push_back(step);
    at->second.push_back(std::move(words));
  }
  return steps;
}

}  // namespace

std::vector<StepMatch> compare_steps(std::string_view expected, std::string_view actual) {
  std::vector<long long> order;
  const StepLines want = lines_by_step(expected, &order);
  const StepLines got = lines_by_step(actual, nullptr);
  std::vector<StepMatch> out;
  for (const long long step : order) {
    const auto it = got.find(step);
    out.push_back(StepMatch{step, it != got.end() && it->second == want.at(step)});
  }
  return out;
}

std::optional<Difference> first_difference(std::string_view expected, std::string_view actual) {
  const auto e = split_lines(expected);
  const auto a = split_lines(actual);
  std::optional<Difference> first;
  long count = 0;
  const std::size_t n = std::max(e.size(), a.size());
  for (std::size_t k = 0; k < n; ++k) {
    const std::string_view el = k < e.size() ? e[k] : std::string_view();
    const std::string_view al = k < a.size() ? a[k] : std::string_view();
    if (k < e.size() && k < a.size() && el == al) continue;
    ++count;
    if (first) continue;
    Difference d;
    d.line = static_cast<long>(k + 1);
    const auto ew = split_words(el);
    const auto aw = split_words(al);
    const auto& ref = ew.empty() ? aw : ew;
    if (!ref.empty()) d.step = std::string(ref[0]);
    if (ref.size() > 2) d.particle = std::string(ref[1]);
    if (k >= a.size()) {
      d.field = "line";
      d.expected = std::string(el);
      d.actual = "(missing: the actual output ends here)";
    } else if (k >= e.size()) {
      d.field = "line";
      d.expected = "(missing: the expected output ends here)";
      d.actual = std::string(al);
    } else {
      const std::size_t m = std::max(ew.size(), aw.size());
      for (std::size_t f = 0; f < m; ++f) {
        const std::string_view ev = f < ew.size() ? ew[f] : std::string_view("(none)");
        const std::string_view av = f < aw.size() ? aw[f] : std::string_view("(none)");
        if (ev != av) {
          d.field = field_name(f, ref.size());
          d.expected = std::string(ev);
          d.actual = std::string(av);
          break;
        }
      }
      if (d.field.empty()) {  // same words, different spacing
        d.field = "spacing";
        d.expected = std::string(el);
        d.actual = std::string(al);
      }
    }
    first = d;
  }
  if (first) first->differing_lines = count;
  return first;
}

std::string Difference::describe() const {
  std::ostringstream os;
  os << "first difference at line " << line;
  if (!step.empty()) os << ": step " << step;
  if (!particle.empty()) os << ", particle " << particle;
  os << ", field " << field << "\n  expected: " << expected << "\n  actual:   " << actual << "\n"
     << differing_lines << (differing_lines == 1 ? " line differs" : " lines differ");
  return os.str();
}

}  // namespace plab
