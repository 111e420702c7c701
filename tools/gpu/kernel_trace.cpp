// A kernel timeline for the GPU machine, which has no Nsight Systems: a CUPTI activity tracer
// that the CUDA driver loads into any program through CUDA_INJECTION64_PATH. It records every
// kernel (in CUDA graphs too), copy and memset on the device, and every CUDA runtime call on the
// host, with their start and end in ns, and writes them at exit as CSV to FASCIA_TRACE (default
// trace.csv), one record per line:
//   kind,start_ns,end_ns,stream,graph,size,name
// kind K (kernel; size: its blocks), M (copy; size: bytes, name memcpyN with CUPTI's copy kind:
// 1 host to device, 2 device to host, 8 device to device), S (memset; size: bytes), R (runtime
// call on the host; name: the call). tools/gpu/trace-report summarises a file.
// Built by tools/gpu/bundle into the bundle's lib/; run-on-device's `trace` mode uses it.
#include <cupti.h>
#include <cxxabi.h>

#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>

namespace {

FILE* g_out = nullptr;
std::mutex g_mutex;

void CUPTIAPI request_buffer(uint8_t** buffer, size_t* size, size_t* max_records) {
  *size = 16 << 20;
  *buffer = static_cast<uint8_t*>(std::aligned_alloc(8, *size));
  *max_records = 0;
}

// The kernel's name without its parameter list, commas replaced (CSV).
std::string kernel_name(const char* mangled) {
  int status = 0;
  char* plain = abi::__cxa_demangle(mangled, nullptr, nullptr, &status);
  std::string s = status == 0 && plain ? plain : mangled;
  std::free(plain);
  for (auto at = s.find("(anonymous namespace)::"); at != std::string::npos; at = s.find("(anonymous namespace)::"))
    s.erase(at, 23);
  if (const auto paren = s.find('('); paren != std::string::npos) s.resize(paren);
  for (char& c : s)
    if (c == ',') c = ';';
  return s;
}

void CUPTIAPI buffer_completed(CUcontext, uint32_t, uint8_t* buffer, size_t, size_t valid) {
  std::lock_guard<std::mutex> lock(g_mutex);
  CUpti_Activity* record = nullptr;
  while (g_out && cuptiActivityGetNextRecord(buffer, valid, &record) == CUPTI_SUCCESS) {
    const auto ull = [](uint64_t v) { return static_cast<unsigned long long>(v); };
    switch (record->kind) {
      case CUPTI_ACTIVITY_KIND_CONCURRENT_KERNEL:
      case CUPTI_ACTIVITY_KIND_KERNEL: {
        const auto* k = reinterpret_cast<const CUpti_ActivityKernel10*>(record);
        std::fprintf(g_out, "K,%llu,%llu,%u,%u,%llu,%s\n", ull(k->start), ull(k->end), k->streamId, k->graphId,
                     ull(static_cast<uint64_t>(k->gridX) * k->gridY * k->gridZ), kernel_name(k->name).c_str());
        break;
      }
      case CUPTI_ACTIVITY_KIND_MEMCPY: {
        const auto* m = reinterpret_cast<const CUpti_ActivityMemcpy6*>(record);
        std::fprintf(g_out, "M,%llu,%llu,%u,%u,%llu,memcpy%d\n", ull(m->start), ull(m->end), m->streamId, m->graphId,
                     ull(m->bytes), static_cast<int>(m->copyKind));
        break;
      }
      case CUPTI_ACTIVITY_KIND_MEMSET: {
        const auto* m = reinterpret_cast<const CUpti_ActivityMemset4*>(record);
        std::fprintf(g_out, "S,%llu,%llu,%u,%u,%llu,memset\n", ull(m->start), ull(m->end), m->streamId, m->graphId,
                     ull(m->bytes));
        break;
      }
      case CUPTI_ACTIVITY_KIND_RUNTIME: {
        const auto* a = reinterpret_cast<const CUpti_ActivityAPI*>(record);
        const char* name = nullptr;
        cuptiGetCallbackName(CUPTI_CB_DOMAIN_RUNTIME_API, a->cbid, &name);
        std::fprintf(g_out, "R,%llu,%llu,0,0,0,%s\n", ull(a->start), ull(a->end), name ? name : "?");
        break;
      }
      default:
        break;
    }
  }
  std::free(buffer);
}

void finish() {
  cuptiActivityFlushAll(1);
  std::lock_guard<std::mutex> lock(g_mutex);
  if (g_out) std::fclose(g_out);
  g_out = nullptr;
}

}  // namespace

// Called by the CUDA driver when it loads this library (CUDA_INJECTION64_PATH).
extern "C" int InitializeInjection() {
  const char* path = std::getenv("FASCIA_TRACE");
  g_out = std::fopen(path ? path : "trace.csv", "w");
  if (!g_out) return 0;
  cuptiActivityRegisterCallbacks(request_buffer, buffer_completed);
  for (const CUpti_ActivityKind kind : {CUPTI_ACTIVITY_KIND_CONCURRENT_KERNEL, CUPTI_ACTIVITY_KIND_MEMCPY,
                                        CUPTI_ACTIVITY_KIND_MEMSET, CUPTI_ACTIVITY_KIND_RUNTIME})
    cuptiActivityEnable(kind);
  std::atexit(finish);
  return 1;
}
