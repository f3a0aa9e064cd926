/// \file gputrace/trace.cpp
/// \brief The grader's GPU trace: a CUPTI injection library that records, outside the stage's own
/// code, what a CUDA program ran on the device (every kernel, copy and memset: its stream and
/// its start and end on the GPU's clock) and writes it as JSON when the program exits.
///
/// The CUDA driver loads it into any CUDA program, the static runtime's included, when
/// `CUDA_INJECTION64_PATH` names it, and calls InitializeInjection() at its own initialisation.
/// `PLAB_GPU_TRACE` names the JSON file it writes (nothing is written without it):
///
///     {"kernels": K, "kernel_ns": T, "by_name": {"name": [count, ns], ...},
///      "copies": {"htod": bytes, "dtoh": bytes, "dtod": bytes, "other": bytes, "count": C},
///      "memsets": M, "streams": {"id": {"kernels": k, "copies": c, "memsets": m}, ...},
///      "intervals": [[kind, stream, start_ns, end_ns], ...], "dropped": D,
///      "memory": {"allocations": A, "allocated_bytes": B, "frees": F, "live": L,
///                 "live_bytes": LB, "managed_bytes": MB}}
///
/// kind is 0 for a kernel, 1 a copy, 2 a memset; `intervals` holds the first kMaxIntervals of
/// them (`dropped` counts the others). The grader (kit/python/plab/grade/gpu_idea.py) reads it: kernels per
/// step and their device time (stage 04), kernels on two streams at the same time (stage 05),
/// the device time of a large scene (stage 06's GPU path), and the device memory the program
/// allocated and left allocated at exit, and whether any was managed (stage 04's exercise 1). A
/// graph's kernels carry the stream the graph was launched on.
#include <cupti.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace {

constexpr std::size_t kBufferBytes = 8u << 20;       // one activity buffer
constexpr std::size_t kMaxIntervals = 4'000'000;     // kept for the overlap measure

/// One activity on the device.
struct Interval {
  int kind;  // 0 kernel, 1 copy, 2 memset
  std::uint32_t stream;
  std::uint64_t start, end;
};

/// Counts per stream.
struct PerStream {
  long long kernels = 0, copies = 0, memsets = 0;
};

/// Everything recorded so far (the buffers complete on CUPTI's own thread).
struct Trace {
  std::mutex lock;
  long long kernels = 0, memsets = 0, copies = 0, dropped = 0;
  std::uint64_t kernel_ns = 0;
  std::uint64_t htod = 0, dtoh = 0, dtod = 0, other = 0;
  std::map<std::string, std::pair<long long, std::uint64_t>> by_name;
  std::map<std::uint32_t, PerStream> streams;
  std::vector<Interval> intervals;
  long long allocations = 0, frees = 0;
  std::uint64_t allocated_bytes = 0, managed_bytes = 0;
  std::map<std::uint64_t, std::uint64_t> live;  // address -> bytes, of allocations not freed
  bool written = false;
};

Trace& trace() {
  static Trace* t = new Trace;  // never destroyed: the exit handler still uses it
  return *t;
}

void keep(Trace& t, int kind, std::uint32_t stream, std::uint64_t start, std::uint64_t end) {
  if (t.intervals.size() < kMaxIntervals)
    t.intervals.push_back({kind, stream, start, end});
  else
    ++t.dropped;
}

void CUPTIAPI buffer_requested(std::uint8_t** buffer, std::size_t* size, std::size_t* max_records) {
  *buffer = static_cast<std::uint8_t*>(std::aligned_alloc(8, kBufferBytes));
  *size = *buffer ? kBufferBytes : 0;
  *max_records = 0;
}

void CUPTIAPI buffer_completed(CUcontext, std::uint32_t, std::uint8_t* buffer, std::size_t,
                               std::size_t valid) {
  Trace& t = trace();
  std::lock_guard<std::mutex> hold(t.lock);
  CUpti_Activity* record = nullptr;
  while (cuptiActivityGetNextRecord(buffer, valid, &record) == CUPTI_SUCCESS) {
    switch (record->kind) {
      case CUPTI_ACTIVITY_KIND_KERNEL:
      case CUPTI_ACTIVITY_KIND_CONCURRENT_KERNEL: {
        const auto* k = reinterpret_cast<const CUpti_ActivityKernel10*>(record);
        const std::uint64_t ns = k->end > k->start ? k->end - k->start : 0;
        ++t.kernels;
        t.kernel_ns += ns;
        auto& n = t.by_name[k->name ? k->name : "?"];
        ++n.first;
        n.second += ns;
        ++t.streams[k->streamId].kernels;
        keep(t, 0, k->streamId, k->start, k->end);
        break;
      }
      case CUPTI_ACTIVITY_KIND_MEMCPY: {
        const auto* c = reinterpret_cast<const CUpti_ActivityMemcpy6*>(record);
        ++t.copies;
        switch (c->copyKind) {
          case CUPTI_ACTIVITY_MEMCPY_KIND_HTOD: t.htod += c->bytes; break;
          case CUPTI_ACTIVITY_MEMCPY_KIND_DTOH: t.dtoh += c->bytes; break;
          case CUPTI_ACTIVITY_MEMCPY_KIND_DTOD: t.dtod += c->bytes; break;
          default: t.other += c->bytes; break;
        }
        ++t.streams[c->streamId].copies;
        keep(t, 1, c->streamId, c->start, c->end);
        break;
      }
      case CUPTI_ACTIVITY_KIND_MEMSET: {
        const auto* m = reinterpret_cast<const CUpti_ActivityMemset4*>(record);
        ++t.memsets;
        ++t.streams[m->streamId].memsets;
        keep(t, 2, m->streamId, m->start, m->end);
        break;
      }
      case CUPTI_ACTIVITY_KIND_MEMORY2: {
        const auto* m = reinterpret_cast<const CUpti_ActivityMemory4*>(record);
        if (m->memoryOperationType == CUPTI_ACTIVITY_MEMORY_OPERATION_TYPE_ALLOCATION) {
          ++t.allocations;
          t.allocated_bytes += m->bytes;
          if (m->memoryKind == CUPTI_ACTIVITY_MEMORY_KIND_MANAGED) t.managed_bytes += m->bytes;
          t.live[m->address] = m->bytes;
        } else if (m->memoryOperationType == CUPTI_ACTIVITY_MEMORY_OPERATION_TYPE_RELEASE) {
          ++t.frees;
          t.live.erase(m->address);
        }
        break;
      }
      default:
        break;
    }
  }
  std::size_t lost = 0;
  if (cuptiActivityGetNumDroppedRecords(nullptr, 0, &lost) == CUPTI_SUCCESS) t.dropped += lost;
  std::free(buffer);
}

/// A JSON string's body (kernel names are mangled C++: letters, digits, _ and a few symbols).
std::string escaped(const std::string& s) {
  std::string out;
  for (const char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) >= 0x20) out += c;
  }
  return out;
}

/// Flushes CUPTI's buffers and writes the JSON (once).
void write_trace() {
  const char* path = std::getenv("PLAB_GPU_TRACE");
  cuptiActivityFlushAll(1);
  Trace& t = trace();
  std::lock_guard<std::mutex> hold(t.lock);
  if (t.written || path == nullptr || *path == '\0') return;
  t.written = true;
  std::FILE* f = std::fopen(path, "w");
  if (f == nullptr) return;
  std::fprintf(f, "{\"kernels\": %lld, \"kernel_ns\": %llu, \"memsets\": %lld, \"dropped\": %lld,\n",
               t.kernels, static_cast<unsigned long long>(t.kernel_ns), t.memsets, t.dropped);
  std::fprintf(f, " \"copies\": {\"htod\": %llu, \"dtoh\": %llu, \"dtod\": %llu, \"other\": %llu, "
               "\"count\": %lld},\n", static_cast<unsigned long long>(t.htod),
               static_cast<unsigned long long>(t.dtoh), static_cast<unsigned long long>(t.dtod),
               static_cast<unsigned long long>(t.other), t.copies);
  std::fprintf(f, " \"by_name\": {");
  const char* sep = "";
  for (const auto& [name, n] : t.by_name) {
    std::fprintf(f, "%s\"%s\": [%lld, %llu]", sep, escaped(name).c_str(), n.first,
                 static_cast<unsigned long long>(n.second));
    sep = ", ";
  }
  std::fprintf(f, "},\n \"streams\": {");
  sep = "";
  for (const auto& [id, s] : t.streams) {
    std::fprintf(f, "%s\"%u\": {\"kernels\": %lld, \"copies\": %lld, \"memsets\": %lld}", sep, id,
                 s.kernels, s.copies, s.memsets);
    sep = ", ";
  }
  std::fprintf(f, "},\n \"intervals\": [");
  sep = "";
  for (const Interval& i : t.intervals) {
    std::fprintf(f, "%s[%d, %u, %llu, %llu]", sep, i.kind, i.stream,
                 static_cast<unsigned long long>(i.start), static_cast<unsigned long long>(i.end));
    sep = ",\n  ";
  }
  std::uint64_t live_bytes = 0;
  for (const auto& [address, bytes] : t.live) live_bytes += bytes;
  std::fprintf(f, "],\n \"memory\": {\"allocations\": %lld, \"allocated_bytes\": %llu, "
               "\"frees\": %lld, \"live\": %zu, \"live_bytes\": %llu, \"managed_bytes\": %llu}}\n",
               t.allocations, static_cast<unsigned long long>(t.allocated_bytes), t.frees,
               t.live.size(), static_cast<unsigned long long>(live_bytes),
               static_cast<unsigned long long>(t.managed_bytes));
  std::fclose(f);
}

}  // namespace

/// Called by the CUDA driver when it loads this library (CUDA_INJECTION64_PATH): turns on the
/// activity records and writes them at exit. Returns 1 (loaded).
extern "C" __attribute__((visibility("default"))) int InitializeInjection() {
  if (cuptiActivityRegisterCallbacks(buffer_requested, buffer_completed) != CUPTI_SUCCESS)
    return 0;
  cuptiActivityEnable(CUPTI_ACTIVITY_KIND_CONCURRENT_KERNEL);
  cuptiActivityEnable(CUPTI_ACTIVITY_KIND_MEMCPY);
  cuptiActivityEnable(CUPTI_ACTIVITY_KIND_MEMSET);
  cuptiActivityEnable(CUPTI_ACTIVITY_KIND_MEMORY2);  // allocations and frees (stage 04)
  std::atexit(write_trace);
  return 1;
}
