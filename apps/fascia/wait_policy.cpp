// libgomp's wait policy for the fascia executable: passive unless the environment chooses.
//
// With libgomp's default policy, a thread that reaches the end of a parallel loop spins (up to
// GOMP_SPINCOUNT = 300,000 iterations) before it sleeps. fascia's loops are short (a Newton
// iteration is tens of them), so on a machine whose cores are busy with other work the spinning
// threads take the timeslices the working ones need: `fascia study beam --method frame-hex
// --resolution 64x4x4` took 60 s wall and 65 s CPU on a 2-core machine at a load
// of about 1, 22 s and 11 s with OMP_WAIT_POLICY=passive; at 32x2x2 and a load of 11, 20-27 s
// against 1.3-1.8 s (docs/solvers.md). On the same machine without other work, `fascia bench cpu`
// moved by less between the two policies than between repeated runs.
//
// libgomp reads the policy once, in its initialiser, which runs before main(). The functions of
// the executable's .preinit_array run before the initialiser of any shared library (System V
// ABI, "Initialization and Termination Functions"), but before libc's too: a setenv() there is
// undone when libc sets its environment from the process's. So the process executes itself once
// more with OMP_WAIT_POLICY=passive added to its environment (same process id, arguments and
// descriptors; nothing has run yet). Where that fails (no /proc), it continues with libgomp's
// default. OMP_WAIT_POLICY or GOMP_SPINCOUNT in the environment (active spinning on a
// dedicated node) is left as it is, and ends the recursion.
#include <cstring>

#include <unistd.h>

namespace {

bool chooses_wait(const char* entry) {
  return std::strncmp(entry, "OMP_WAIT_POLICY=", 16) == 0 || std::strncmp(entry, "GOMP_SPINCOUNT=", 15) == 0;
}

// Runs before libc and libstdc++ are initialised: system calls and string functions only, no
// allocation.
void passive_openmp_wait(int, char** argv, char** envp) {
  static char passive[] = "OMP_WAIT_POLICY=passive";
  static char* environment[4096];
  constexpr int kMaxEntries = 4094;  // room for the added entry and the terminating null
  int n = 0;
  for (; envp && envp[n]; ++n) {
    if (chooses_wait(envp[n]) || n >= kMaxEntries) return;
    environment[n] = envp[n];
  }
  environment[n] = passive;
  environment[n + 1] = nullptr;
  execve("/proc/self/exe", argv, environment);  // returns only on failure: libgomp's default then
}

__attribute__((section(".preinit_array"), used)) void (*const preinit_wait_policy)(int, char**, char**) =
    &passive_openmp_wait;

}  // namespace
