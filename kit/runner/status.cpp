/// \file runner/status.cpp
/// \brief The status file: "DONE TOTAL" rewritten in place after each step, so that `plab run`
/// can say where a run was when it hung or crashed.
#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <stdexcept>

#include "runner.hpp"

namespace plab::runner {

namespace {

/// A stepper that writes "DONE TOTAL" to a status file after each step, and passes every other
/// question to the stage's own stepper (a question left out answers the base class's default:
/// `plab run --ranks` once printed no bytes line because traffic() was).
class StatusStepper final : public Stepper {
 public:
  StatusStepper(std::unique_ptr<Stepper> inner, int fd, long long total)
      : inner_(std::move(inner)), fd_(fd), total_(total) {
    write_status();
  }
  void step() override {
    inner_->step();
    ++done_;
    write_status();
  }
  void read(Particles& p) override { inner_->read(p); }
  [[nodiscard]] double own_seconds() const override { return inner_->own_seconds(); }
  [[nodiscard]] std::string device() const override { return inner_->device(); }
  [[nodiscard]] std::size_t device_bytes() const override { return inner_->device_bytes(); }
  [[nodiscard]] double memory_bandwidth() const override { return inner_->memory_bandwidth(); }
  Traffic traffic() override { return inner_->traffic(); }  // every rank asks: a collective

 private:
  void write_status() {
    char line[64];
    const int n = std::snprintf(line, sizeof line, "%20lld %20lld\n", done_, total_);
    if (fd_ >= 0 && pwrite(fd_, line, n, 0) < 0) fd_ = -1;
  }
  std::unique_ptr<Stepper> inner_;
  int fd_;
  long long total_;
  long long done_ = 0;
};

}  // namespace

MakeStepper with_status(MakeStepper make, const std::string& path, long long total) {
  if (path.empty()) return make;
  const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot write the status file " + path);
  return [make, fd, total](const Box& box, Particles& p) -> std::unique_ptr<Stepper> {
    return std::make_unique<StatusStepper>(make(box, p), fd, total);
  };
}

}  // namespace plab::runner
