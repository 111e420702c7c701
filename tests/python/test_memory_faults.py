"""Memory faults: an allocation that fails beyond what --max-memory estimated is reported as
"out of memory" with exit 71 (too large), not as a solver failure (1) or a crash."""
import resource
import subprocess


def limited_address_space(limit_bytes):
    def apply():
        resource.setrlimit(resource.RLIMIT_AS, (limit_bytes, limit_bytes))
    return apply


def test_an_allocation_beyond_the_address_space_is_out_of_memory(fascia_bin, root):
    # 200 x 200 x 100 hexahedra (32 M samples) need tens of GiB; --max-memory lets the estimate
    # through, and a 4 GiB address-space limit makes the discretisation's allocation fail. Not
    # less: the CUDA libraries the program links (cuBLAS) must still map at start.
    r = subprocess.run([fascia_bin, "check", "scenes/tool_pull.yaml", "--set", "objects.slab.box.cells=[200,200,100]",
                        "--max-memory", "100G"], cwd=root, capture_output=True, text=True, timeout=120,
                       preexec_fn=limited_address_space(4 << 30))
    assert r.returncode == 71, r.stderr
    assert "out of memory" in r.stderr, r.stderr
