"""`fascia check` on mutated scenes, as a user runs it (a process per scene, includes, the output
path check, --set): it ends with a documented exit code, never a signal or a hang, and a refusal
names file:line:col. The in-process fuzz (tests/dsl/test_fuzz_scenes.cpp) covers many more
mutations of parsing and building; this one covers what lies around them. FASCIA_FUZZ_RUNS and
FASCIA_FUZZ_SEED choose how many and which."""
import os
import random
import re
import shutil
import subprocess
from pathlib import Path

DOCUMENTED = {0, 64, 65, 66, 71, 74, 78}
LOCATED = re.compile(r"^(\S+\.yaml|--set|-o):\d+:\d+: ", re.M)

EXTREMES = ["0", "-1", "1e308", "1e-300", "2147483648", "99999999999999999999", "nan", ".inf", "1e155", "[]",
            "{}", "~", "/dev/zero", "/", "1 km", "1e-9 mm"]
FRAGMENTS = ["{", "}", "[", "]", ": ", ", ", "- ", "&a ", "*a", "---\n", "\t", "'", '"', "include: base.yaml\n",
             "include: /dev/urandom\n", "extends: [base.yaml, base.yaml]\n", "output: {file: /}\n",
             "output: {file: no_such_dir/x.h5}\n", "x" * 5000]


def mutate(text, rng):
    for _ in range(rng.randint(1, 3)):
        how = rng.randrange(5)
        if how == 0:
            spots = [m.span() for m in re.finditer(r"\d[\w.+-]*", text)]
            if spots:
                a, b = rng.choice(spots)
                text = text[:a] + rng.choice(EXTREMES) + text[b:]
        elif how == 1:
            at = rng.randrange(len(text) + 1)
            text = text[:at] + rng.choice(FRAGMENTS) + text[at:]
        elif how == 2:
            lines = text.splitlines(True)
            if lines:
                del lines[rng.randrange(len(lines))]
            text = "".join(lines)
        elif how == 3:
            text = text[:rng.randrange(len(text) + 1)]
        else:
            at = rng.randrange(len(text) + 1)
            text = text[:at] + chr(rng.randrange(1, 256)) + text[at + 1:]
    return text


def test_mutated_scenes_end_with_documented_codes_and_located_messages(fascia_bin, root, tmp_path):
    runs = int(os.environ.get("FASCIA_FUZZ_RUNS", "24"))
    rng = random.Random(int(os.environ.get("FASCIA_FUZZ_SEED", "20261124")))
    # The scenes with their meshes, and a base scene to include, in a scratch copy.
    shutil.copytree(root / "scenes", tmp_path / "scenes")
    (tmp_path / "scenes" / "base.yaml").write_text("materials:\n  base: {young: 1 kPa}\n")
    seeds = sorted(p for p in (root / "scenes").glob("*.yaml"))
    codes = set()
    for run in range(runs):
        seed = rng.choice(seeds)
        text = mutate(seed.read_text(), rng)
        scene = tmp_path / "scenes" / f"fuzz_{run}.yaml"
        scene.write_text(text, encoding="latin-1")
        args = [fascia_bin, "check", str(scene.relative_to(tmp_path)), "--max-memory", "64M"]
        if rng.randrange(4) == 0:
            args += ["--set", rng.choice(["materials.fasica.young=1kPa", "solver.dt=1e-300s", "run.steps=2147483647",
                                          "objects=" + "x" * 5000, "output.file=/"])]
        r = subprocess.run(args, cwd=tmp_path, capture_output=True, text=True, errors="replace", timeout=60)
        context = f"run {run}, mutation of {seed.name}:\n{text[:1500]}\nstderr:\n{r.stderr[-2000:]}"
        assert r.returncode >= 0, context  # no signal
        assert r.returncode in DOCUMENTED, context
        if r.returncode != 0:
            assert LOCATED.search(r.stderr), context
        codes.add(r.returncode)
    assert len(codes) > 1, codes
