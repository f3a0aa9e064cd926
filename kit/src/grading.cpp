/// \file grading.cpp
/// \brief The autograder's helper that runs in the stage's program: one step from each state.
#include "plab/grading.hpp"

#include "plab/io.hpp"

namespace plab {

void step_from_each(const Box& box, const std::vector<OutputBlock>& blocks,
                    const MakeStepper& make, std::FILE* out) {
  OutputWriter writer(out);
  for (std::size_t k = 0; k < blocks.size(); ++k) {
    Particles p = blocks[k].particles;
    const auto stage = make(box, p);
    stage->step();
    stage->read(p);
    writer.block(blocks[k].step + 1, p, false);
  }
  writer.flush();
}

}  // namespace plab
