/// \file cuda/particles.hpp
/// \brief The plain view of the particles that kernels take: one device array per field.
#pragma once

#include "plab/scene.hpp"

namespace plab::cuda {

/// What a kernel receives: the device pointers of every field and the count (a plain struct,
/// passed by value).
struct ParticlesView {
  double* x;       //!< centre x
  double* y;       //!< centre y
  double* vx;      //!< velocity x
  double* vy;      //!< velocity y
  long long* pc;   //!< pair collisions so far
  long long* wc;   //!< wall collisions so far
  int n;           //!< number of particles
};

}  // namespace plab::cuda
