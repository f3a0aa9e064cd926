/// \file unwritten.hpp
/// \brief Instructor only: Buffer<T>, a std::vector whose resize leaves the elements it adds
/// unwritten, for the engines' working arrays (host code).
#pragma once

#include <cstddef>
#include <memory>
#include <utility>
#include <vector>

namespace plab {

/// An allocator that leaves the elements a resize adds unwritten (default-initialised), so that
/// a buffer's pages are first written, and so mapped by the system, by the threads that use it,
/// in parallel, and not zeroed by the one thread that grows it (at N = 10^6 the first step's
/// buffers are some 200 MB).
template <class T>
struct Unwritten : std::allocator<T> {
  /// The same allocator for elements of type U (what a container asks of an allocator).
  template <class U>
  struct rebind {
    using other = Unwritten<U>;  //!< this allocator, for U
  };
  Unwritten() = default;
  /// From the allocator of another element type (it holds nothing).
  template <class U>
  Unwritten(const Unwritten<U>&) noexcept {}
  /// Constructs an element at `at`: with no arguments, default-initialised (a number is left
  /// unwritten); otherwise from `args`.
  template <class U, class... Args>
  void construct(U* at, Args&&... args) {
    if constexpr (sizeof...(Args) == 0)
      ::new (static_cast<void*>(at)) U;
    else
      ::new (static_cast<void*>(at)) U(std::forward<Args>(args)...);
  }
};

/// A step's working array of N or so elements (Unwritten).
template <class T>
using Buffer = std::vector<T, Unwritten<T>>;

/// Resizes `v` to `size` unwritten elements, dropping what it held: when it must grow, it takes
/// room for `size` and a quarter more, and copies nothing (a copy would write, and so map, the
/// new pages in this one thread).
template <class T>
void resize_dropping(Buffer<T>& v, std::size_t size) {
  if (size > v.capacity()) {
    v.clear();
    v.reserve(size + size / 4);
  }
  v.resize(size);
}

}  // namespace plab
