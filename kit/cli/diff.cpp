/// \file cli/diff.cpp
/// \brief `plab diff`: where two outputs first differ.
#include "common.hpp"

namespace plab::cli {

void add_diff(CLI::App& app) {
  auto files = std::make_shared<std::vector<std::string>>();
  auto* c = app.add_subcommand("diff", "Compare two outputs (or digest files): exit 0 when equal, "
                                       "otherwise show the first differing step, particle and "
                                       "field, and count the differing lines.");
  c->add_option("files", *files, "EXPECTED ACTUAL")->required()->expected(2)
      ->check(CLI::ExistingFile);
  c->callback([files] {
    const auto d = first_difference(read_file((*files)[0]), read_file((*files)[1]));
    if (!d) {
      std::printf("equal\n");
      return;
    }
    std::printf("%s\n", d->describe().c_str());
    g_status = 1;
  });
}

}  // namespace plab::cli
