//! vitrum's cluster recipes run for real: the Slurm scripts (`scripts/slurm/`) on a single-node
//! Slurm cluster that the test starts on localhost, and the GNU parallel one-liner of docs/scale-out.md.
//!
//! - The cluster: `munged`, `slurmctld` and `slurmd` run as root in the foreground, with their
//!   key, sockets, state, spool and logs in a temporary folder, on free ports, from a `slurm.conf`
//!   written here (every Slurm command sees it through `SLURM_CONF`). It is torn down when the test
//!   ends, also when it fails; a daemon that does not come up fails the test with its log.
//! - `submit.sh` renders 4 shards as a job array and the merge job combines them: the merged image
//!   is the single render of the same options.
//! - A task requeued while it renders (`scontrol requeue`) is killed mid-way, runs again and
//!   resumes its checkpoint (its log says so, Slurm counts the restart); the merge is still the
//!   single render.
//! - Tasks that fail leave vitrum's error in their logs, and the merge is cancelled.
//! - The `parallel … --shard {}/16 … && vitrum merge …` line of docs/scale-out.md, with a small render.
//!
//! Merged shards equal the single render within f64 summation rounding (relative 1e-6), not bit
//! for bit: partial sums round differently from one running sum (see `vitrum::parts` and
//! `tests/parts.rs`).
//!
//! Needs root and Debian's `slurm-wlm`, `munge` and `parallel` (`.ci/run` installs them). Without
//! them each test prints what it did not run and passes (see `common::system`).

use std::fs;
use std::net::TcpListener;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::{Mutex, MutexGuard};
use std::thread::sleep;
use std::time::{Duration, Instant};
use vitrum::image::Image;
use vitrum::output::exr::read_exr;
use vitrum::output::film::read_part;

mod common;
use common::system::{is_root, may_run, missing_programs};

const VITRUM: &str = env!("CARGO_BIN_EXE_vitrum");
const SCRIPTS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/slurm");
const SCENES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes");
const SCALE_OUT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/docs/scale-out.md");
/// The scene every render here splits.
const SCENE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/cornell-glass.toml");
/// The test cluster's one node (`slurmd -N`; its `NodeHostname` is this machine's).
const NODE: &str = "vitrum0";
/// How long a daemon may take to come up (generous: a slow, busy machine).
const STARTUP: Duration = Duration::from_secs(120);
/// How long a job may take to finish.
const JOB_TIMEOUT: Duration = Duration::from_secs(600);
/// The interval between two looks at a daemon or a job.
const POLL: Duration = Duration::from_millis(200);
/// How long a stopped daemon may take to exit before it is killed.
const STOP_GRACE: Duration = Duration::from_secs(5);
/// The test cluster's `AuthInfo` `cred_expire`, in seconds: the least Slurm takes (default 120).
/// A requeued job is held this long plus 1 s before it may start again. Lifting the hold
/// (`scontrol update JobId=… StartTime=now`) is no shortcut: a relaunch within the second of the
/// kill is refused ("Job credential revoked") and the task fails.
const CRED_EXPIRE: u32 = 5;
/// The states a job ends in.
const FINAL_STATES: [&str; 9] = [
    "COMPLETED",
    "FAILED",
    "CANCELLED",
    "TIMEOUT",
    "NODE_FAIL",
    "OUT_OF_MEMORY",
    "BOOT_FAIL",
    "DEADLINE",
    "PREEMPTED",
];

/// One test at a time (each keeps both cores busy).
static SERIAL: Mutex<()> = Mutex::new(());

/// Holds the test lock.
fn serial() -> MutexGuard<'static, ()> {
    SERIAL.lock().unwrap_or_else(|e| e.into_inner())
}

/// The last `lines` lines of the file `path` (or why it cannot be read).
fn tail(path: &Path, lines: usize) -> String {
    match fs::read_to_string(path) {
        Ok(text) => {
            let all: Vec<&str> = text.lines().collect();
            all[all.len().saturating_sub(lines)..].join("\n")
        }
        Err(e) => format!("({}: {e})", path.display()),
    }
}

/// A daemon run in the foreground, its output in `log`; stopped (SIGTERM, SIGKILL after
/// [`STOP_GRACE`]) and waited for when dropped. It stays in the test's process group, so that a
/// Ctrl-C of the test stops it as well.
struct Daemon {
    name: &'static str,
    child: Child,
    log: PathBuf,
}

impl Daemon {
    /// Starts `command` as the daemon `name`, its stdout and stderr to `log`.
    fn start(name: &'static str, mut command: Command, log: PathBuf) -> Daemon {
        let file = fs::File::create(&log).unwrap_or_else(|e| panic!("{}: {e}", log.display()));
        let stderr = file.try_clone().expect("a second handle to the log");
        command.stdin(Stdio::null()).stdout(file).stderr(stderr);
        let child = command.spawn().unwrap_or_else(|e| {
            panic!("cannot start {name}: {e} (install Debian's slurm-wlm and munge, as .ci/run does)")
        });
        Daemon { name, child, log }
    }

    /// Why the daemon is not running any more, if it is not.
    fn exited(&mut self) -> Option<String> {
        let status = self.child.try_wait().ok().flatten()?;
        Some(format!("{} exited ({status})", self.name))
    }
}

impl Drop for Daemon {
    fn drop(&mut self) {
        if self.exited().is_some() {
            return; // already reaped: its pid may be another process's by now
        }
        // SIGTERM first: slurmctld then ends its slurmscriptd, which would linger otherwise.
        let pid = self.child.id().to_string();
        let _ = Command::new("kill").args(["-TERM", &pid]).stderr(Stdio::null()).status();
        let deadline = Instant::now() + STOP_GRACE;
        while self.exited().is_none() && Instant::now() < deadline {
            sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The processes whose environment holds `entry` (`NAME=value`); zombies have none.
fn processes_with_env(entry: &str) -> Vec<u32> {
    let Ok(proc) = fs::read_dir("/proc") else { return Vec::new() };
    proc.filter_map(|e| e.ok()?.file_name().to_str()?.parse::<u32>().ok())
        .filter(|pid| {
            let environ = fs::read(format!("/proc/{pid}/environ")).unwrap_or_default();
            environ.split(|&b| b == 0).any(|var| var == entry.as_bytes())
        })
        .collect()
}

/// Kills (SIGKILL) every process whose environment holds `entry` and waits until none is left:
/// slurmctld's slurmscriptd and the jobs' step daemons, scripts and renders (slurmd starts these
/// in sessions of their own).
fn kill_processes_with_env(entry: &str) {
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let pids = processes_with_env(entry);
        if pids.is_empty() {
            return;
        }
        if Instant::now() > deadline {
            eprintln!("slurm_cluster: processes {pids:?} with {entry} survived SIGKILL");
            return;
        }
        let pids: Vec<String> = pids.iter().map(u32::to_string).collect();
        let _ = Command::new("kill").arg("-KILL").args(&pids).stderr(Stdio::null()).status();
        sleep(POLL);
    }
}

/// Panics unless the test runs as root (the Slurm daemons must, to run jobs).
fn assert_root() {
    let status = fs::read_to_string("/proc/self/status").expect("/proc/self/status");
    let uid = status.lines().find_map(|l| l.strip_prefix("Uid:")).and_then(|l| l.split_whitespace().next());
    assert_eq!(uid, Some("0"), "the Slurm cluster test starts slurmctld and slurmd as root: run it as root");
}

/// This machine's short host name (what slurmd and slurmctld call it).
fn short_hostname() -> String {
    let name = fs::read_to_string("/proc/sys/kernel/hostname").expect("/proc/sys/kernel/hostname");
    name.trim().split('.').next().unwrap_or_default().to_string()
}

/// Two distinct TCP ports free on every interface (for slurmctld and slurmd).
fn free_ports() -> (u16, u16) {
    let bind = || TcpListener::bind("0.0.0.0:0").expect("a free port");
    let (a, b) = (bind(), bind());
    (a.local_addr().unwrap().port(), b.local_addr().unwrap().port())
}

/// The value of `key` in a `Key=value` record (`scontrol -o`, `slurmd -C`).
fn field<'a>(record: &'a str, key: &str) -> Option<&'a str> {
    record.split_whitespace().find_map(|kv| kv.strip_prefix(key)?.strip_prefix('='))
}

/// The minimal slurm.conf of a one-node cluster with everything under `dir`: munge
/// authentication through the socket `dir/munge/munge.socket`, no cgroups, no accounting, a
/// scheduler that starts jobs at once, and requeued jobs held for [`CRED_EXPIRE`]. `hardware` is
/// the node's CPU layout, `ports` slurmctld's and slurmd's.
fn slurm_conf(dir: &Path, hardware: &str, (ctld_port, slurmd_port): (u16, u16)) -> String {
    let d = dir.display();
    let host = short_hostname();
    format!(
        "ClusterName=vitrumtest
SlurmctldHost={host}(127.0.0.1)
SlurmctldPort={ctld_port}
SlurmdPort={slurmd_port}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={d}/munge/munge.socket,cred_expire={CRED_EXPIRE}
StateSaveLocation={d}/state
SlurmdSpoolDir={d}/spool
SlurmctldPidFile={d}/slurmctld.pid
SlurmdPidFile={d}/slurmd.pid
SlurmctldLogFile={d}/log/slurmctld.log
SlurmdLogFile={d}/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
SchedulerParameters=batch_sched_delay=0,sched_interval=1
ReturnToService=2
MinJobAge=600
KillWait=5
NodeName={NODE} NodeHostname={host} NodeAddr=127.0.0.1 {hardware} State=UNKNOWN
PartitionName=test Nodes={NODE} Default=YES MaxTime=INFINITE State=UP
"
    )
}

/// The job ids of one `submit.sh` submission.
struct Submission {
    array: String,
    merge: String,
}

impl Submission {
    /// Reads submit.sh's last line, `submitted: N shards (job array A) and their merge (job M) …`.
    fn parse(stdout: &str) -> Option<Submission> {
        let line = stdout.lines().rfind(|l| l.starts_with("submitted: "))?;
        let number_after = |marker: &str| {
            let rest = &line[line.find(marker)? + marker.len()..];
            let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
            (!digits.is_empty()).then_some(digits)
        };
        Some(Submission { array: number_after("(job array ")?, merge: number_after("merge (job ")? })
    }

    /// The id of array task `index`.
    fn task(&self, index: u32) -> String {
        format!("{}_{index}", self.array)
    }

    /// The log of array task `index` (render-shard.sbatch's `--output`, in the submission folder).
    fn task_log(&self, dir: &Path, index: u32) -> PathBuf {
        dir.join(format!("vitrum-shard-{}_{index}.log", self.array))
    }
}

/// A single-node Slurm cluster on localhost in a temporary folder, torn down when dropped.
struct Cluster {
    /// The daemons in the order they started (stopped in reverse).
    daemons: Vec<Daemon>,
    conf: PathBuf,
    dir: tempfile::TempDir,
}

impl Cluster {
    /// Starts munged, slurmctld and slurmd, and waits until the node is idle.
    fn start() -> Cluster {
        assert_root();
        let dir = tempfile::Builder::new().prefix("vitrum-slurm-").tempdir().expect("a temporary folder");
        // munged refuses a socket in a folder that others cannot search.
        fs::set_permissions(dir.path(), fs::Permissions::from_mode(0o755)).unwrap();
        for sub in ["munge", "state", "spool", "log"] {
            fs::create_dir(dir.path().join(sub)).unwrap();
        }
        let conf = dir.path().join("slurm.conf");
        // From here on a failure drops the cluster, which stops what has started.
        let mut cluster = Cluster { daemons: Vec::new(), conf, dir };
        cluster.start_munged();
        let conf = slurm_conf(cluster.dir(), &cluster.node_hardware(), free_ports());
        fs::write(&cluster.conf, conf).unwrap();
        cluster.start_slurmctld();
        cluster.start_slurmd();
        cluster
    }

    /// The cluster's folder (also the folder jobs are submitted from).
    fn dir(&self) -> &Path {
        self.dir.path()
    }

    /// A file of the cluster's folder.
    fn path(&self, name: &str) -> PathBuf {
        self.dir().join(name)
    }

    /// `program`, run in the cluster's folder with `SLURM_CONF` set.
    fn command(&self, program: &str) -> Command {
        let mut command = Command::new(program);
        command.current_dir(self.dir()).env("SLURM_CONF", &self.conf).stdin(Stdio::null());
        command
    }

    /// Runs `command` to its end (`what` names it in a failure).
    fn output(&self, command: &mut Command, what: &str) -> Output {
        command.output().unwrap_or_else(|e| {
            self.fail(&format!(
                "cannot run {what}: {e} (install Debian's slurm-wlm and munge, as .ci/run does)"
            ))
        })
    }

    /// Runs `command` and returns its stdout; fails the test unless it succeeds.
    fn succeed(&self, command: &mut Command, what: &str) -> String {
        let out = self.output(command, what);
        if !out.status.success() {
            let stderr = String::from_utf8_lossy(&out.stderr);
            self.fail(&format!("{what} failed ({}): {stderr}", out.status));
        }
        String::from_utf8_lossy(&out.stdout).into_owned()
    }

    /// `scontrol ARGS`'s stdout; fails the test unless it succeeds.
    fn scontrol(&self, args: &[&str]) -> String {
        self.succeed(self.command("scontrol").args(args), &format!("scontrol {}", args.join(" ")))
    }

    /// `scontrol ARGS`'s stdout, empty when it fails (a daemon not up yet, a job not known yet).
    fn try_scontrol(&self, args: &[&str]) -> String {
        let out = self.command("scontrol").args(args).output();
        out.map(|o| String::from_utf8_lossy(&o.stdout).into_owned()).unwrap_or_default()
    }

    /// Starts `command` as the daemon `name` (its output in `log/NAME.out`) and waits until
    /// `ready` says it is up.
    fn launch(&mut self, name: &'static str, command: Command, mut ready: impl FnMut(&Cluster) -> bool) {
        let log = self.path(&format!("log/{name}.out"));
        self.daemons.push(Daemon::start(name, command, log));
        self.wait_until(&format!("{name} to come up"), STARTUP, |c| ready(c).then_some(()));
    }

    /// Creates a munge key (mode 0400) and starts munged on its own socket.
    fn start_munged(&mut self) {
        let key = self.path("munge/munge.key");
        let mut mungekey = Command::new("mungekey");
        mungekey.arg("--create").arg(format!("--keyfile={}", key.display()));
        self.succeed(&mut mungekey, "mungekey --create");
        fs::set_permissions(&key, fs::Permissions::from_mode(0o400)).unwrap();
        let mut munged = Command::new("munged");
        munged.arg("--foreground").arg(format!("--key-file={}", key.display()));
        for (option, file) in [
            ("--socket", "munge.socket"),
            ("--pid-file", "munged.pid"),
            ("--log-file", "munged.log"),
            ("--seed-file", "munged.seed"),
        ] {
            munged.arg(format!("{option}={}", self.path("munge").join(file).display()));
        }
        self.launch("munged", munged, |c| c.path("munge/munge.socket").exists());
    }

    /// This machine's CPU layout as `slurmd -C` counts it, as slurm.conf node fields.
    fn node_hardware(&self) -> String {
        let out = self.succeed(self.command("slurmd").arg("-C"), "slurmd -C");
        let line = out.lines().next().unwrap_or_default();
        let keys = ["CPUs", "Boards", "SocketsPerBoard", "CoresPerSocket", "ThreadsPerCore"];
        let fields: Vec<String> =
            keys.iter().filter_map(|k| field(line, k).map(|v| format!("{k}={v}"))).collect();
        if field(line, "CPUs").is_none() {
            self.fail(&format!("slurmd -C gives no CPUs: {out}"));
        }
        fields.join(" ")
    }

    /// Starts slurmctld and waits until it answers `scontrol ping`.
    fn start_slurmctld(&mut self) {
        let mut slurmctld = self.command("slurmctld");
        slurmctld.arg("-D");
        self.launch("slurmctld", slurmctld, |c| c.try_scontrol(&["ping"]).contains("is UP"));
    }

    /// Starts slurmd as the node and waits until the node is idle.
    fn start_slurmd(&mut self) {
        let mut slurmd = self.command("slurmd");
        slurmd.args(["-D", "-N", NODE]);
        self.launch("slurmd", slurmd, |c| {
            field(&c.try_scontrol(&["-o", "show", "node", NODE]), "State") == Some("IDLE")
        });
    }

    /// Polls `probe` until it gives a value; fails the test after `timeout` or when a daemon
    /// has died.
    fn wait_until<T>(
        &mut self,
        what: &str,
        timeout: Duration,
        mut probe: impl FnMut(&Cluster) -> Option<T>,
    ) -> T {
        let start = Instant::now();
        loop {
            if let Some(value) = probe(self) {
                return value;
            }
            if let Some(why) = self.daemons.iter_mut().find_map(Daemon::exited) {
                self.fail(&format!("{why} while waiting for {what}"));
            }
            if start.elapsed() > timeout {
                self.fail(&format!("waited {timeout:?} for {what}"));
            }
            sleep(POLL);
        }
    }

    /// Fails the test with `message` and what the daemons and jobs logged.
    fn fail(&self, message: &str) -> ! {
        panic!("{message}\n{}", self.diagnostics())
    }

    /// The daemons' log tails, the jobs' logs and Slurm's job records.
    fn diagnostics(&self) -> String {
        let mut text = String::new();
        for daemon in &self.daemons {
            text += &format!("--- {} ({}):\n{}\n", daemon.name, daemon.log.display(), tail(&daemon.log, 30));
        }
        let mut logs: Vec<PathBuf> = fs::read_dir(self.dir())
            .map(|d| d.filter_map(|e| Some(e.ok()?.path())).collect())
            .unwrap_or_default();
        logs.retain(|p| p.extension().is_some_and(|e| e == "log"));
        logs.sort();
        for log in logs {
            text += &format!("--- {}:\n{}\n", log.display(), tail(&log, 20));
        }
        let jobs = self.try_scontrol(&["-o", "show", "job"]);
        if !jobs.is_empty() {
            text += &format!("--- scontrol show job:\n{jobs}");
        }
        text
    }

    /// Submits `submit.sh SHARDS SCENE OUT OPTIONS` from the cluster's folder, with `VITRUM` the
    /// test binary, one CPU per shard (the scripts ask for 8) and the variables `env`.
    fn submit(&self, shards: u32, out: &str, options: &[&str], env: &[(&str, &str)]) -> Submission {
        let mut submit = self.command("bash");
        submit.arg(format!("{SCRIPTS}/submit.sh")).arg(shards.to_string()).args([SCENE, out]).args(options);
        submit.env("VITRUM", VITRUM).env("SHARD_SBATCH_OPTIONS", "--cpus-per-task=1");
        submit.envs(env.iter().copied());
        let stdout = self.succeed(&mut submit, "submit.sh");
        Submission::parse(&stdout)
            .unwrap_or_else(|| self.fail(&format!("submit.sh printed no job ids: {stdout}")))
    }

    /// Slurm's record of the job `id` (`scontrol -o show job`: one line of `Key=value`).
    fn job(&self, id: &str) -> String {
        self.scontrol(&["-o", "show", "job", id])
    }

    /// The state of the job `id` (empty when Slurm cannot say).
    fn job_state(&self, id: &str) -> String {
        field(&self.try_scontrol(&["-o", "show", "job", id]), "JobState").unwrap_or_default().to_string()
    }

    /// Waits until the job `id` is in `state`; fails the test if it ends in another.
    fn wait_for_state(&mut self, id: &str, state: &str) {
        let reached = self.wait_until(&format!("job {id} to be {state}"), JOB_TIMEOUT, |c| {
            let now = c.job_state(id);
            (now == state || FINAL_STATES.contains(&now.as_str())).then_some(now)
        });
        if reached != state {
            self.fail(&format!("job {id} is {reached}, not {state}"));
        }
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        while let Some(daemon) = self.daemons.pop() {
            drop(daemon);
        }
        kill_processes_with_env(&format!("SLURM_CONF={}", self.conf.display()));
    }
}

/// The value of `name` in `options` (`--spp 32` → `32`).
fn option<'a>(options: &[&'a str], name: &str) -> &'a str {
    let at = options.iter().position(|o| *o == name).unwrap_or_else(|| panic!("no {name} in {options:?}"));
    options[at + 1]
}

/// The sample indices of shard `index` of `count` of an `spp`-sample render, as vitrum writes
/// them (`spp·I/N .. spp·(I+1)/N`).
fn shard_samples(index: u32, count: u32, spp: u32) -> String {
    format!("{}..{}", spp * index / count, spp * (index + 1) / count)
}

/// The sample indices a render part holds (`vitrum:samples`).
fn part_samples(path: &Path) -> Result<String, String> {
    let file = read_part(path).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(file.part.info.samples.to_string())
}

/// Largest relative difference between two images' channels.
fn max_relative_difference(a: &Image, b: &Image) -> f64 {
    let rel = |x: f32, y: f32| ((x - y).abs() as f64) / (y.abs() as f64).max(1e-30);
    a.pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| [rel(p.x, q.x), rel(p.y, q.y), rel(p.z, q.z)])
        .fold(0.0, f64::max)
}

/// Renders SCENE with `options` in one process (`single-NAME` beside `merged`) and checks that
/// the merged shards are that render: all its sample indices, the same rays, the same pixels
/// within f64 summation rounding (relative 1e-6, far below an f32 ulp of most pixels).
fn assert_is_the_single_render(merged: &Path, options: &[&str]) {
    let name = merged.file_name().unwrap().to_str().unwrap();
    let single = merged.with_file_name(format!("single-{name}"));
    let out = Command::new(VITRUM)
        .args(["render", SCENE, "--quiet", "-o"])
        .arg(&single)
        .args(options)
        .output()
        .expect("the single render");
    assert!(out.status.success(), "the single render: {}", String::from_utf8_lossy(&out.stderr));
    let (merged_image, merged_meta) = read_exr(merged).unwrap_or_else(|e| panic!("{name}: {e}"));
    let (single_image, single_meta) = read_exr(&single).unwrap();
    let spp = option(options, "--spp");
    assert_eq!(merged_meta["vitrum:samples"], format!("0..{spp}"), "{name}: every sample index");
    assert_eq!(merged_meta["vitrum:rays"], single_meta["vitrum:rays"], "{name}: the same rays were traced");
    let worst = max_relative_difference(&merged_image, &single_image);
    assert!(worst <= 1e-6, "{name} differs from the single render by {worst:e}");
    assert!(merged_image.pixels.iter().any(|p| p.max_element() > 0.0), "{name}: a black image");
}

/// submit.sh's 4 shards render as array tasks of one CPU each and merge into the single render.
fn shards_submitted_by_submit_sh_merge_into_the_single_render(cluster: &mut Cluster) {
    let options = ["-i", "path", "--spp", "26", "--resolution", "48x48", "--seed", "3"];
    let comment = ("MERGE_SBATCH_OPTIONS", "--comment=vitrum-test-merge");
    let jobs = cluster.submit(4, "four.exr", &options, &[comment]);
    cluster.wait_for_state(&jobs.merge, "COMPLETED");
    let merge = cluster.job(&jobs.merge);
    assert_eq!(field(&merge, "Comment"), Some("vitrum-test-merge"), "MERGE_SBATCH_OPTIONS: {merge}");
    for index in 0..4 {
        let task = cluster.job(&jobs.task(index));
        assert_eq!(field(&task, "JobState"), Some("COMPLETED"), "{task}");
        assert_eq!(field(&task, "NumCPUs"), Some("1"), "SHARD_SBATCH_OPTIONS: {task}");
        let log = fs::read_to_string(jobs.task_log(cluster.dir(), index)).unwrap_or_default();
        assert!(log.contains(&format!("rendering shard {index}/4 into four.parts/")), "task {index}: {log}");
        let part = cluster.path(&format!("four.parts/part-{index}-of-4.exr"));
        assert_eq!(part_samples(&part), Ok(shard_samples(index, 4, 26)), "task {index}");
    }
    assert_is_the_single_render(&cluster.path("four.exr"), &options);
}

/// A task requeued while it renders is killed with part of its samples checkpointed, runs again,
/// resumes the checkpoint, and the merge is the single render.
fn a_requeued_task_resumes_its_checkpoint(cluster: &mut Cluster) {
    // About 6 s per shard on one core with the wavefront engine of `path` (AVX-512 here): time to
    // see a checkpoint and requeue long before the end.
    let (spp, shards) = (6400, 2);
    let spp_text = spp.to_string();
    let options = ["-i", "path", "--spp", &spp_text, "--resolution", "64x64", "--seed", "5"];
    let jobs = cluster.submit(shards, "requeued.exr", &options, &[("CHECKPOINT_SECONDS", "1")]);
    let (task, part) = (jobs.task(0), cluster.path("requeued.parts/part-0-of-2.exr"));
    let target = shard_samples(0, shards, spp);
    let checkpointed = cluster.wait_until(&format!("task {task} to run and checkpoint"), JOB_TIMEOUT, |c| {
        let state = c.job_state(&task);
        if FINAL_STATES.contains(&state.as_str()) {
            // Finished before a checkpoint was seen: the render is too short for this machine.
            return Some(Err(state));
        }
        let held = part_samples(&part).ok().filter(|s| *s != "0..0" && *s != target)?;
        (state == "RUNNING").then_some(Ok(held))
    });
    let checkpointed = checkpointed.unwrap_or_else(|state| {
        cluster.fail(&format!("task {task} ended ({state}) before a checkpoint was seen"))
    });
    cluster.scontrol(&["requeue", &task]);
    // Killed and held pending (CRED_EXPIRE): what the first run left is the part resumed.
    cluster.wait_for_state(&task, "PENDING");
    let held = part_samples(&part).unwrap_or_else(|e| cluster.fail(&e));
    assert_ne!(held, target, "the task finished before the requeue killed it (checkpoint {checkpointed})");
    cluster.wait_for_state(&jobs.merge, "COMPLETED");

    let record = cluster.job(&task);
    assert_eq!(field(&record, "Restarts"), Some("1"), "{record}");
    let log = fs::read_to_string(jobs.task_log(cluster.dir(), 0)).unwrap_or_default();
    let first = log.find("rendering shard 0/2 into requeued.parts/part-0-of-2.exr");
    let resumed = log.find("resuming requeued.parts/part-0-of-2.exr (shard 0/2, restart 1)");
    assert!(
        matches!((first, resumed), (Some(a), Some(b)) if a < b) && !log.contains("nothing to render"),
        "the log keeps the first run, then the resume of the checkpoint (held {held}):\n{log}"
    );
    assert_eq!(part_samples(&part), Ok(target), "the resumed task rendered the rest of its shard");
    assert_is_the_single_render(&cluster.path("requeued.exr"), &options);
    eprintln!("slurm_cluster: task {task} requeued holding the samples {held}, resumed to the end");
}

/// A task that fails leaves its error in its log, and the merge is cancelled rather than left
/// pending forever (`--kill-on-invalid-dep`).
fn a_failed_task_cancels_the_merge(cluster: &mut Cluster) {
    let options = ["-i", "ssaa", "--spp", "4", "--resolution", "16x16"];
    let jobs = cluster.submit(2, "failed.exr", &options, &[]);
    cluster.wait_for_state(&jobs.merge, "CANCELLED");
    for index in 0..2 {
        assert_eq!(cluster.job_state(&jobs.task(index)), "FAILED", "task {index}");
        let log = fs::read_to_string(jobs.task_log(cluster.dir(), index)).unwrap_or_default();
        assert!(log.contains("`ssaa` cannot be rendered in parts"), "task {index}: {log}");
    }
    assert!(!cluster.path("failed.exr").exists(), "no merged image");
}

/// The programs the cluster test runs.
const CLUSTER_PROGRAMS: [&str; 6] = ["munged", "mungekey", "slurmctld", "slurmd", "sbatch", "scontrol"];

#[test]
fn the_slurm_scripts_render_requeue_resume_and_merge_on_a_real_cluster() {
    let mut missing = missing_programs(&CLUSTER_PROGRAMS);
    if !is_root() {
        missing.push("root (the Slurm daemons run jobs as root)".to_owned());
    }
    if !may_run(&missing, "apt-get install slurm-wlm munge, and run the test as root") {
        return;
    }
    let _serial = serial();
    let start = Instant::now();
    let mut cluster = Cluster::start();
    let up = start.elapsed();
    shards_submitted_by_submit_sh_merge_into_the_single_render(&mut cluster);
    let first = start.elapsed();
    a_requeued_task_resumes_its_checkpoint(&mut cluster);
    let second = start.elapsed();
    a_failed_task_cancels_the_merge(&mut cluster);
    let third = start.elapsed();
    drop(cluster);
    eprintln!(
        "slurm_cluster: cluster up in {:.1} s, 4 shards merged at {:.1} s, requeue resumed and merged at \
         {:.1} s, failed tasks cancelled the merge at {:.1} s, torn down: {:.1} s in all",
        up.as_secs_f64(),
        first.as_secs_f64(),
        second.as_secs_f64(),
        third.as_secs_f64(),
        start.elapsed().as_secs_f64()
    );
}

/// What keeps `parallel` from being GNU parallel (moreutils has another `parallel`): nothing, or
/// one line.
fn missing_gnu_parallel() -> Vec<String> {
    match Command::new("parallel").arg("--version").output() {
        Err(_) => vec!["GNU parallel".to_owned()],
        Ok(out) if !String::from_utf8_lossy(&out.stdout).starts_with("GNU parallel") => {
            vec!["GNU parallel (the `parallel` on the PATH is another program)".to_owned()]
        }
        Ok(_) => Vec::new(),
    }
}

/// The first line of the first code block after the line with `marker` in the scale-out page.
fn documented_command_after(marker: &str) -> String {
    let page = fs::read_to_string(SCALE_OUT).expect("docs/scale-out.md");
    let at = page.find(marker).unwrap_or_else(|| panic!("docs/scale-out.md: no {marker}"));
    let mut lines = page[at..].lines().skip_while(|l| !l.starts_with("```"));
    let fence = lines.next().unwrap_or_default();
    let line = lines.next().unwrap_or_default().trim();
    assert!(fence.starts_with("```") && !line.is_empty(), "docs/scale-out.md: no command after {marker}");
    line.to_string()
}

#[test]
fn the_documented_gnu_parallel_one_liner_renders_shards_that_merge_into_the_single_render() {
    if !may_run(&missing_gnu_parallel(), "apt-get install parallel") {
        return;
    }
    let _serial = serial();
    let start = Instant::now();
    let line = documented_command_after("**GNU parallel**");
    assert!(line.contains("scenes/cornell-glass.toml") && line.contains("--spp 65536"), "{line}");
    // The documented command as written, with its render made small.
    let small =
        line.replace("scenes/", &format!("{SCENES}/")).replace("--spp 65536", "--spp 32 --resolution 32x32");
    let dir = tempfile::tempdir().unwrap();
    let bin = Path::new(VITRUM).parent().unwrap();
    let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap_or_default());
    let out = Command::new("sh").arg("-c").arg(&small).current_dir(dir.path()).env("PATH", path).output();
    let out = out.expect("sh");
    assert!(out.status.success(), "{small}: {}", String::from_utf8_lossy(&out.stderr));
    for index in 0..16 {
        let part = dir.path().join(format!("parts/{index}.exr"));
        assert_eq!(part_samples(&part), Ok(shard_samples(index, 16, 32)), "shard {index}");
    }
    assert_is_the_single_render(
        &dir.path().join("ref.exr"),
        &["-i", "path", "--spp", "32", "--resolution", "32x32"],
    );
    eprintln!("slurm_cluster: the GNU parallel one-liner in {:.1} s", start.elapsed().as_secs_f64());
}
