"""A one-node Slurm cluster on localhost for tests: munged, slurmctld and slurmd from Debian 12,
started in a scratch folder with a generated slurm.conf and stopped by their process ids.

SlurmCluster.start() raises SlurmUnavailable with the reason when the daemons are missing, the
process is not root (slurmd must be), or the node does not come up."""
import os
import shutil
import socket
import subprocess
import time
from pathlib import Path


class SlurmUnavailable(Exception):
    pass


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class SlurmCluster:
    def __init__(self, folder):
        self.dir = Path(folder)
        self.processes = []
        self.env = dict(os.environ)

    def run(self, *args, check=True, timeout=60):
        r = subprocess.run(list(args), env=self.env, capture_output=True, text=True, timeout=timeout)
        if check and r.returncode != 0:
            raise RuntimeError(f"{' '.join(args)}: exit {r.returncode}: {r.stderr.strip()}")
        return r

    def start(self):
        for program in ("munged", "mungekey", "slurmctld", "slurmd", "sbatch", "squeue", "scontrol"):
            if not shutil.which(program) and not Path("/usr/sbin", program).exists():
                raise SlurmUnavailable(f"{program} is not installed (tools/install-deps installs Slurm)")
        if os.geteuid() != 0:
            raise SlurmUnavailable("slurmd needs root")
        d = self.dir
        for sub in ("munge", "state", "spool", "log"):
            (d / sub).mkdir(parents=True, exist_ok=True)
        os.chmod(d / "munge", 0o700)
        key = d / "munge" / "munge.key"
        subprocess.run(["mungekey", "--create", "--keyfile", str(key), "--force"], check=True, capture_output=True)
        os.chmod(key, 0o600)
        socket_path = d / "munge" / "munge.sock"
        self.spawn(["munged", "--foreground", "--force", f"--key-file={key}", f"--socket={socket_path}",
                    f"--pid-file={d / 'munge' / 'munged.pid'}", f"--log-file={d / 'log' / 'munged.log'}",
                    f"--seed-file={d / 'munge' / 'munged.seed'}"])
        self.wait_for(lambda: socket_path.exists(), 20, "munged did not create its socket")
        host = socket.gethostname()
        cpus = os.cpu_count() or 1
        conf = d / "slurm.conf"
        conf.write_text(f"""ClusterName=fasciatest
SlurmctldHost={host}(127.0.0.1)
SlurmctldPort={free_port()}
SlurmdPort={free_port()}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={socket_path}
StateSaveLocation={d / 'state'}
SlurmdSpoolDir={d / 'spool'}
SlurmctldPidFile={d / 'slurmctld.pid'}
SlurmdPidFile={d / 'slurmd.pid'}
SlurmctldLogFile={d / 'log' / 'slurmctld.log'}
SlurmdLogFile={d / 'log' / 'slurmd.log'}
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SlurmdParameters=config_overrides
MpiDefault=none
ReturnToService=2
JobRequeue=1
KillWait=10
MinJobAge=600
InactiveLimit=0
NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN
PartitionName=test Nodes={host} Default=YES MaxTime=INFINITE State=UP
""")
        self.env["SLURM_CONF"] = str(conf)
        self.spawn(["slurmctld", "-D", "-i", "-f", str(conf)])
        self.spawn(["slurmd", "-D", "-f", str(conf), "-N", host])
        self.host = host

        def node_up():
            r = self.run("sinfo", "-h", "-N", "-o", "%T", check=False)
            return r.returncode == 0 and r.stdout.strip().startswith(("idle", "mixed", "allocated"))
        self.wait_for(node_up, 60, "the node did not come up")

    def spawn(self, argv):
        log = open(self.dir / "log" / (Path(argv[0]).name + ".out"), "w")
        p = subprocess.Popen(argv, env=self.env, stdout=log, stderr=subprocess.STDOUT)
        self.processes.append((p, log))
        time.sleep(0.2)
        if p.poll() is not None:
            raise SlurmUnavailable(f"{argv[0]} exited with {p.returncode}: {self.logs()}")

    def wait_for(self, condition, timeout, message):
        start = time.time()
        while time.time() - start < timeout:
            if condition():
                return
            for p, _ in self.processes:
                if p.poll() is not None:
                    raise SlurmUnavailable(f"{p.args[0]} exited with {p.returncode}: {self.logs()}")
            time.sleep(0.5)
        raise SlurmUnavailable(f"{message}: {self.logs()}")

    def logs(self):
        out = []
        for f in sorted((self.dir / "log").glob("*")):
            text = f.read_text(errors="replace").strip().splitlines()[-8:]
            out.append(f"--- {f.name}\n" + "\n".join(text))
        return "\n".join(out)

    def stop(self):
        # In reverse order, each by its process id: slurmd, slurmctld, munged.
        for p, log in reversed(self.processes):
            if p.poll() is None:
                p.terminate()
                try:
                    p.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    p.kill()
                    p.wait(timeout=30)
            log.close()
        self.processes = []
