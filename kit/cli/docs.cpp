/// \file cli/docs.cpp
/// \brief `plab docs`: build the HTML docs with Doxygen.
#include "common.hpp"

namespace plab::cli {

void add_docs(CLI::App& app) {
  auto* c = app.add_subcommand("docs", "Build the HTML docs (Doxygen with Graphviz; warnings are "
                                       "errors) into build/docs/html.");
  c->callback([] {
    g_status = run_program({"cmake", "--build", build_dir(), "--target", "docs"});
    if (g_status == 0) std::printf("docs: %s/docs/html/index.html\n", build_dir().c_str());
  });
}

}  // namespace plab::cli
