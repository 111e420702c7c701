"""The fascia executable runs libgomp with the passive wait policy unless the environment chooses
one (apps/fascia/wait_policy.cpp). With OMP_DISPLAY_ENV=verbose libgomp prints what it read at
start-up, once per process: once here, so the re-execution happens before libgomp starts. Its
OMP_WAIT_POLICY line reads 'PASSIVE' when the policy is unset too; GOMP_SPINCOUNT tells them apart
(0 passive, 300000 libgomp's default, 30000000000 active)."""
import os
import subprocess


def displayed(fascia_bin, **extra):
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    env.update(extra, OMP_DISPLAY_ENV="verbose")
    r = subprocess.run([fascia_bin, "--version"], env=env, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith("fascia ")
    shown = {}
    for line in r.stderr.splitlines():
        for name in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT"):
            if line.strip().startswith(name + " ="):
                assert name not in shown, "libgomp started twice"
                shown[name] = line.split("=")[1].strip().strip("'")
    return shown


def test_passive_by_default(fascia_bin):
    assert displayed(fascia_bin) == {"OMP_WAIT_POLICY": "PASSIVE", "GOMP_SPINCOUNT": "0"}


def test_the_environment_chooses(fascia_bin):
    assert displayed(fascia_bin, OMP_WAIT_POLICY="active")["OMP_WAIT_POLICY"] == "ACTIVE"
    assert displayed(fascia_bin, GOMP_SPINCOUNT="1000")["GOMP_SPINCOUNT"] == "1000"
