//! `farm/slurm` on a real Slurm: a one-node cluster (munged, slurmctld, slurmd) started from a
//! temporary directory, the frame submitted with `farm/slurm/submit.sh`, shards stopped by the
//! time limit's early signal and by preemption, requeued and resumed from their checkpoints,
//! and the merge compared with a single render of the same settings. Then a shard that never
//! runs: the merge fails loudly and the command it prints finishes the frame; and the same
//! with `--allow-missing`. The daemons are stopped by PID, also when the test fails.
//!
//! Skipped, with a message, where Slurm and munge are not installed (`apt-get install slurm-wlm
//! munge`) or the test does not run as root (slurmd must); with REALCAM_REQUIRE_SLURM=1 (as
//! `.ci/run` sets) it fails instead. Also the usage errors of `submit.sh`, which need no Slurm.

use std::fs;
use std::io::Write;
use std::net::TcpListener;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

const REPO: &str = env!("CARGO_MANIFEST_DIR");
const REALCAM: &str = env!("CARGO_BIN_EXE_realcam");

fn scene() -> PathBuf {
    Path::new(REPO).join("tests/data/CornellBox/cornellBox-2.80-Eevee-gltf.gltf")
}

fn submit_script() -> PathBuf {
    Path::new(REPO).join("farm/slurm/submit.sh")
}

/// Prints past the test harness's capture, so that a skip and the measurements show in
/// `cargo test`'s output.
fn report(text: &str) {
    let _ = writeln!(std::io::stderr(), "farm::slurm: {text}");
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// `program` on PATH or in the sbin folders where Debian puts the daemons.
fn find_program(program: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path)
        .chain(["/usr/sbin", "/usr/local/sbin", "/sbin"].map(PathBuf::from))
        .map(|dir| dir.join(program))
        .find(|candidate| candidate.is_file())
}

/// Why the cluster cannot be started here, if it cannot.
fn cannot_run_slurm() -> Option<String> {
    let tools = [
        "munged",
        "slurmctld",
        "slurmd",
        "sbatch",
        "srun",
        "squeue",
        "scontrol",
        "scancel",
        "sinfo",
    ];
    let missing: Vec<&str> = tools
        .into_iter()
        .filter(|tool| find_program(tool).is_none())
        .collect();
    if !missing.is_empty() {
        return Some(format!(
            "Slurm is not installed ({} not found; apt-get install slurm-wlm munge)",
            missing.join(", ")
        ));
    }
    let uid = Command::new("id").arg("-u").output().ok()?;
    if text(&uid.stdout).trim() != "0" {
        return Some("not root (slurmd runs jobs as root here)".to_string());
    }
    None
}

/// A free TCP port on this machine (bound and released; the daemons bind it right after).
fn free_port() -> (TcpListener, u16) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    (listener, port)
}

/// Polls `check` every half second until it gives a value; past `limit`, panics with `what`
/// and `diagnostics()`.
fn wait_for<T>(
    what: &str,
    limit: Duration,
    diagnostics: impl Fn() -> String,
    mut check: impl FnMut() -> Option<T>,
) -> T {
    let deadline = Instant::now() + limit;
    loop {
        if let Some(value) = check() {
            return value;
        }
        if Instant::now() > deadline {
            panic!(
                "timed out after {} s waiting for {what}\n{}",
                limit.as_secs(),
                diagnostics()
            );
        }
        std::thread::sleep(Duration::from_millis(500));
    }
}

/// A one-node cluster whose configuration, state, spool, sockets and logs live in `dir`.
struct Cluster {
    dir: tempfile::TempDir,
    conf: PathBuf,
    /// The daemons this test started, in start order: munged, slurmctld, slurmd.
    daemons: Vec<(&'static str, Child)>,
}

const NODE: &str = "realcam-node";

impl Cluster {
    fn start() -> Cluster {
        let dir = tempfile::Builder::new()
            .prefix("realcam-slurm-")
            .tempdir()
            .unwrap();
        // munged insists that every folder above its socket is searchable by all, and that its
        // key is readable by its owner only.
        fs::set_permissions(dir.path(), fs::Permissions::from_mode(0o755)).unwrap();
        for sub in ["key", "munge", "state", "spool", "log"] {
            fs::create_dir(dir.path().join(sub)).unwrap();
        }
        fs::set_permissions(dir.path().join("key"), fs::Permissions::from_mode(0o700)).unwrap();
        let key = dir.path().join("key/munge.key");
        let mut random = vec![0u8; 1024];
        std::io::Read::read_exact(&mut fs::File::open("/dev/urandom").unwrap(), &mut random)
            .unwrap();
        fs::write(&key, &random).unwrap();
        fs::set_permissions(&key, fs::Permissions::from_mode(0o600)).unwrap();

        let mut cluster = Cluster {
            conf: dir.path().join("slurm.conf"),
            dir,
            daemons: Vec::new(),
        };
        let d = cluster.dir.path().to_path_buf();
        let socket = d.join("munge/munge.socket");
        cluster.spawn(
            "munged",
            &[
                "--foreground".as_ref(),
                format!("--socket={}", socket.display()).as_ref(),
                format!("--key-file={}", key.display()).as_ref(),
                format!("--pid-file={}", d.join("munge/munged.pid").display()).as_ref(),
                format!("--seed-file={}", d.join("key/munged.seed").display()).as_ref(),
                format!("--log-file={}", d.join("log/munged.log").display()).as_ref(),
            ],
        );
        wait_for(
            "munged's socket",
            Duration::from_secs(20),
            || cluster.diagnostics(),
            || socket.exists().then_some(()),
        );

        let (ctld_listener, ctld_port) = free_port();
        let (slurmd_listener, slurmd_port) = free_port();
        drop((ctld_listener, slurmd_listener));
        let host = fs::read_to_string("/proc/sys/kernel/hostname").unwrap();
        let host = host.trim().split('.').next().unwrap().to_string();
        let config = format!(
            "# A one-node test cluster (tests/farm/slurm.rs).
ClusterName=realcamtest
SlurmctldHost={host}(127.0.0.1)
SlurmctldPort={ctld_port}
SlurmdPort={slurmd_port}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
# cred_expire is also how long a requeued job waits before it may start again (120 s by
# default); sched_interval is how often pending jobs are looked at (60 s by default). Both are
# shortened to keep the test short; neither changes what the farm scripts do.
AuthInfo=socket={socket},cred_expire=5
SchedulerType=sched/builtin
SchedulerParameters=sched_interval=1
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
PreemptType=preempt/partition_prio
PreemptMode=REQUEUE
ProctrackType=proctrack/pgid
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
MailProg=/bin/true
MinJobAge=3600
ReturnToService=2
SlurmdParameters=config_overrides
StateSaveLocation={state}
SlurmdSpoolDir={spool}
SlurmctldPidFile={d}/slurmctld.pid
SlurmdPidFile={d}/slurmd.pid
SlurmctldLogFile={d}/log/slurmctld.log
SlurmdLogFile={d}/log/slurmd.log
NodeName={NODE} NodeHostname={host} NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN
PartitionName=farm Nodes={NODE} Default=YES MaxTime=INFINITE State=UP PriorityTier=1
PartitionName=urgent Nodes={NODE} MaxTime=INFINITE State=UP PriorityTier=2
",
            socket = socket.display(),
            state = d.join("state").display(),
            spool = d.join("spool").display(),
            d = d.display(),
        );
        fs::write(&cluster.conf, config).unwrap();
        let conf = cluster.conf.display().to_string();
        cluster.spawn(
            "slurmctld",
            &["-D".as_ref(), "-i".as_ref(), "-f".as_ref(), conf.as_ref()],
        );
        cluster.spawn(
            "slurmd",
            &[
                "-D".as_ref(),
                "-N".as_ref(),
                NODE.as_ref(),
                "-f".as_ref(),
                conf.as_ref(),
            ],
        );
        wait_for(
            "the node to be idle",
            Duration::from_secs(90),
            || cluster.diagnostics(),
            || {
                // One line per partition the node is in.
                let state = cluster.run("sinfo", &["--noheader", "--Node", "--format=%T"]);
                let states = text(&state.stdout);
                (!states.trim().is_empty() && states.lines().all(|line| line.trim() == "idle"))
                    .then_some(())
            },
        );
        cluster
    }

    fn spawn(&mut self, daemon: &'static str, args: &[&std::ffi::OsStr]) {
        let log = fs::File::create(self.dir.path().join(format!("log/{daemon}.out"))).unwrap();
        let child = Command::new(find_program(daemon).unwrap())
            .args(args)
            .env("SLURM_CONF", &self.conf)
            .stdin(Stdio::null())
            .stdout(log.try_clone().unwrap())
            .stderr(log)
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {daemon}: {e}"));
        self.daemons.push((daemon, child));
    }

    /// A Slurm command (or any program) with this cluster's configuration.
    fn command(&self, program: impl AsRef<std::ffi::OsStr>) -> Command {
        let program = program.as_ref();
        let path = find_program(&program.to_string_lossy()).unwrap_or_else(|| program.into());
        let mut command = Command::new(path);
        command
            .env("SLURM_CONF", &self.conf)
            .env("REALCAM", REALCAM)
            .stdin(Stdio::null());
        command
    }

    fn run(&self, program: &str, args: &[&str]) -> Output {
        self.command(program).args(args).output().unwrap()
    }

    /// `Field=value` of `scontrol show job ID`.
    fn job_field(&self, id: &str, field: &str) -> Option<String> {
        let output = self.run("scontrol", &["--oneliner", "show", "job", id]);
        text(&output.stdout)
            .split_whitespace()
            .find_map(|pair| pair.strip_prefix(&format!("{field}=")).map(str::to_string))
    }

    /// Waits until job `id` has ended and returns its final state.
    fn wait_until_ended(&self, id: &str, limit: Duration, logs: &Path) -> String {
        const ENDED: [&str; 9] = [
            "COMPLETED",
            "FAILED",
            "CANCELLED",
            "TIMEOUT",
            "NODE_FAIL",
            "PREEMPTED",
            "OUT_OF_MEMORY",
            "BOOT_FAIL",
            "DEADLINE",
        ];
        wait_for(
            &format!("job {id} to end"),
            limit,
            || format!("{}{}", folder_contents(logs), self.diagnostics()),
            || {
                self.job_field(id, "JobState")
                    .filter(|state| ENDED.contains(&state.as_str()))
            },
        )
    }

    fn diagnostics(&self) -> String {
        let queue = self.run("squeue", &["--all", "--format=%i %P %j %T %r %M %l"]);
        format!(
            "--- squeue\n{}{}{}",
            text(&queue.stdout),
            text(&queue.stderr),
            folder_contents(&self.dir.path().join("log"))
        )
    }
}

/// The contents of every file in `dir` (the cluster's or the frame's logs), for failures.
fn folder_contents(dir: &Path) -> String {
    let mut out = String::new();
    let mut entries: Vec<PathBuf> = fs::read_dir(dir)
        .map(|entries| entries.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    entries.sort();
    for path in entries {
        let content = fs::read_to_string(&path).unwrap_or_default();
        let lines: Vec<&str> = content.lines().collect();
        let tail = &lines[lines.len().saturating_sub(60)..];
        out += &format!("--- {}\n{}\n", path.display(), tail.join("\n"));
    }
    out
}

impl Drop for Cluster {
    fn drop(&mut self) {
        if std::thread::panicking() {
            report(&format!("the cluster's state:\n{}", self.diagnostics()));
        }
        // The jobs first, so that slurmd's step daemons end with them (SIGKILL to every process
        // of a job: a shard must not save, requeue itself and outlive the cluster).
        if self.daemons.len() == 3 {
            let jobs = self.run("squeue", &["--noheader", "--format=%A"]);
            let ids: Vec<String> = text(&jobs.stdout)
                .split_whitespace()
                .map(str::to_string)
                .collect();
            if !ids.is_empty() {
                let mut kill = vec!["--full", "--signal=KILL"];
                kill.extend(ids.iter().map(String::as_str));
                self.run("scancel", &kill);
                self.run(
                    "scancel",
                    &ids.iter().map(String::as_str).collect::<Vec<_>>(),
                );
                let deadline = Instant::now() + Duration::from_secs(60);
                while Instant::now() < deadline {
                    let left = self.run("squeue", &["--noheader"]);
                    if text(&left.stdout).trim().is_empty() {
                        break;
                    }
                    std::thread::sleep(Duration::from_millis(500));
                }
            }
        }
        // Then the daemons this test started, newest first, by PID: SIGTERM, then SIGKILL.
        for (name, child) in self.daemons.iter_mut().rev() {
            let _ = Command::new("kill")
                .args(["-TERM", &child.id().to_string()])
                .status();
            let deadline = Instant::now() + Duration::from_secs(20);
            while Instant::now() < deadline && matches!(child.try_wait(), Ok(None)) {
                std::thread::sleep(Duration::from_millis(100));
            }
            if matches!(child.try_wait(), Ok(None)) {
                report(&format!(
                    "{name} (pid {}) ignored SIGTERM; killing it",
                    child.id()
                ));
                let _ = child.kill();
            }
            let _ = child.wait();
        }
    }
}

/// The job ids `submit.sh` printed: (array job, merge job).
fn submitted_jobs(output: &Output) -> (Option<String>, String) {
    let stdout = text(&output.stdout);
    assert!(
        output.status.success(),
        "submit.sh failed:\n{stdout}{}",
        text(&output.stderr)
    );
    let array = stdout
        .lines()
        .find_map(|line| line.strip_prefix("shards: array job "))
        .map(|rest| rest.split([',', ' ']).next().unwrap().to_string());
    let merge = stdout
        .lines()
        .find_map(|line| line.strip_prefix("merge: job "))
        .map(|rest| rest.split(' ').next().unwrap().to_string())
        .unwrap_or_else(|| panic!("no merge job in:\n{stdout}"));
    (array, merge)
}

/// Linear RGB of an EXR written by `--exr`.
fn exr_pixels(path: &Path) -> Vec<f32> {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb32f()
        .into_raw()
}

/// Largest |a − b| / |b| over the channels with b above 1e-3 of the image's largest value
/// (darker values are compared absolutely, against that 1e-3), and the largest |a − b|.
fn differences(merged: &[f32], single: &[f32]) -> (f64, f64) {
    assert_eq!(merged.len(), single.len());
    let peak = single.iter().fold(0f32, |m, v| m.max(v.abs())) as f64;
    let floor = 1e-3 * peak;
    let mut relative = 0f64;
    let mut absolute = 0f64;
    for (&a, &b) in merged.iter().zip(single) {
        let difference = (a as f64 - b as f64).abs();
        absolute = absolute.max(difference);
        relative = relative.max(difference / (b as f64).abs().max(floor));
    }
    (relative, absolute)
}

/// Seconds since 1970 of `2026-11-23T21:15:40Z` (the shard logs' UTC timestamps).
fn epoch_seconds(stamp: &str) -> Option<i64> {
    let stamp = stamp.strip_suffix('Z')?;
    let (date, time) = stamp.split_once('T')?;
    let mut d = date.split('-').map(|p| p.parse::<i64>());
    let (y, m, day) = (d.next()?.ok()?, d.next()?.ok()?, d.next()?.ok()?);
    let mut t = time.split(':').map(|p| p.parse::<i64>());
    let (h, min, s) = (t.next()?.ok()?, t.next()?.ok()?, t.next()?.ok()?);
    // Days from the civil date (Howard Hinnant's algorithm).
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let doy = (153 * (m + if m > 2 { -3 } else { 9 }) + 2) / 5 + day - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    let days = era * 146_097 + doe - 719_468;
    Some(days * 86_400 + h * 3600 + min * 60 + s)
}

/// For every run that the early SIGINT stopped: how many seconds before that run's time limit
/// the shard stopped (from the log's "time limit at" and "stopped by SIGINT" lines).
fn signal_leads(log: &str) -> Vec<i64> {
    let mut leads = Vec::new();
    let mut limit = None;
    for line in log.lines() {
        let stamp = line.split_whitespace().next().and_then(epoch_seconds);
        if let Some((_, end)) = line.split_once(", time limit at ") {
            limit = epoch_seconds(end.trim());
        } else if line.contains("stopped by SIGINT")
            && let (Some(end), Some(now)) = (limit, stamp)
        {
            leads.push(end - now);
        }
    }
    leads
}

/// Renders `settings` on one thread for `spp` samples and returns the seconds per sample pass.
fn seconds_per_pass(dir: &Path, settings: &[String], spp: u32) -> f64 {
    let stats = dir.join("calibration.json");
    let output = Command::new(REALCAM)
        .arg("render")
        .arg(scene())
        .args(settings)
        .args(["--spp", &spp.to_string(), "--threads", "1"])
        .args(["--out".as_ref(), dir.join("calibration.png").as_os_str()])
        .args(["--stats".as_ref(), stats.as_os_str()])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", text(&output.stderr));
    let stats: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(stats).unwrap()).unwrap();
    stats["frames"][0]["render_seconds"].as_f64().unwrap() / spp as f64
}

fn single_render(dir: &Path, settings: &[String], name: &str) -> Vec<f32> {
    let exr = dir.join(format!("{name}.exr"));
    let output = Command::new(REALCAM)
        .arg("render")
        .arg(scene())
        .args(settings)
        .args([
            "--out".as_ref(),
            dir.join(format!("{name}.png")).as_os_str(),
        ])
        .args(["--exr".as_ref(), exr.as_os_str()])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", text(&output.stderr));
    exr_pixels(&exr)
}

fn strings(words: &[&str]) -> Vec<String> {
    words.iter().map(|w| w.to_string()).collect()
}

#[test]
fn a_frame_survives_time_limits_preemption_and_lost_shards_on_a_real_slurm() {
    if let Some(reason) = cannot_run_slurm() {
        if std::env::var("REALCAM_REQUIRE_SLURM").as_deref() == Ok("1") {
            panic!("REALCAM_REQUIRE_SLURM=1 but {reason}");
        }
        report(&format!("SKIPPED the real-Slurm test: {reason}"));
        return;
    }
    let started = Instant::now();
    let cluster = Cluster::start();
    report(&format!(
        "cluster up in {:.1} s",
        started.elapsed().as_secs_f64()
    ));
    let work = tempfile::tempdir().unwrap();

    // --- 1. Two shards of about 50 s each on one core. The time limit is 1 minute (Slurm's
    // smallest) and --stop-before 20 asks for SIGINT 20 s before it, which Slurm sends up to
    // 30 s earlier still (its time-limit check runs every 30 s): so at 10–40 s into every run,
    // and every shard is stopped at least once. Once both are rendering, a job in a
    // higher-priority partition preempts them (PreemptMode=REQUEUE) with SIGTERM.
    let mut settings = strings(&[
        "--width",
        "96",
        "--height",
        "64",
        "--max-depth",
        "3",
        "--seed",
        "7",
    ]);
    let pass = seconds_per_pass(work.path(), &settings, 24);
    let shards = 2u32;
    let spp = ((shards as f64 * 50.0 / pass).ceil() as u32).clamp(64, 40_000);
    settings.extend(strings(&["--spp", &spp.to_string()]));
    report(&format!(
        "{:.1} ms per sample pass on one core: {spp} spp in {shards} shards",
        pass * 1e3
    ));
    let frames = work.path().join("frames");
    let logs = frames.join("logs");
    let farm_start = Instant::now();
    let submitted = cluster
        .command(submit_script())
        .arg(scene())
        .args(["--shards", &shards.to_string()])
        .args(["--out".as_ref(), frames.join("frame.png").as_os_str()])
        .args(["--exr".as_ref(), frames.join("frame.exr").as_os_str()])
        .args(["--time", "1", "--stop-before", "20", "--cpus-per-task", "1"])
        .args(["--max-requeues", "20"])
        .args(&settings)
        .current_dir(work.path())
        .output()
        .unwrap();
    let (array, merge) = submitted_jobs(&submitted);
    let array = array.expect("an array job");

    let log_of = |index: u32| logs.join(format!("frame.shard-{index}.log"));
    wait_for(
        "both shards to render",
        Duration::from_secs(120),
        || format!("{}{}", folder_contents(&logs), cluster.diagnostics()),
        || {
            (0..shards)
                .all(|i| fs::read_to_string(log_of(i)).is_ok_and(|log| log.contains("\nlens ")))
                .then_some(())
        },
    );
    let preemptor = cluster.run(
        "sbatch",
        &[
            "--parsable",
            "--partition=urgent",
            "--cpus-per-task=2",
            "--output=/dev/null",
            "--wrap=sleep 1",
        ],
    );
    assert!(preemptor.status.success(), "{}", text(&preemptor.stderr));

    let state = cluster.wait_until_ended(&merge, Duration::from_secs(600), &logs);
    let farm_seconds = farm_start.elapsed().as_secs_f64();
    let merge_log = fs::read_to_string(logs.join("frame.merge.log")).unwrap_or_default();
    assert_eq!(
        state,
        "COMPLETED",
        "merge job {merge}:\n{merge_log}\n{}",
        folder_contents(&logs)
    );
    assert!(
        merge_log.contains(&format!("{spp} spp from {shards} of {shards} shards")),
        "{merge_log}"
    );

    let mut leads = Vec::new();
    let mut restarts = Vec::new();
    for index in 0..shards {
        let log = fs::read_to_string(log_of(index)).unwrap();
        assert!(!log.contains("FAILED"), "shard {index}:\n{log}");
        assert!(log.contains("finished: wrote"), "shard {index}:\n{log}");
        assert!(
            log.contains("resuming"),
            "shard {index} never resumed:\n{log}"
        );
        assert!(
            !frames
                .join(format!("frame.shard-{index}-of-{shards}.checkpoint.exr"))
                .exists(),
            "a finished shard deletes its checkpoint"
        );
        leads.extend(signal_leads(&log));
        restarts.push(
            cluster
                .job_field(&format!("{array}_{index}"), "Restarts")
                .unwrap_or_default(),
        );
    }
    let logs_text: String = (0..shards)
        .map(|i| fs::read_to_string(log_of(i)).unwrap())
        .collect();
    assert!(
        logs_text.contains("Slurm requeued") && logs_text.contains("(preemption)"),
        "no shard was preempted and requeued by Slurm:\n{logs_text}"
    );
    assert!(
        !leads.is_empty(),
        "no shard was stopped by the time limit's early SIGINT:\n{logs_text}"
    );
    // Slurm's man page: the signal "may be sent up to 60 seconds earlier than specified".
    for &lead in &leads {
        assert!(
            (20 - 3..=20 + 62).contains(&lead),
            "stopped {lead} s before the time limit with --signal=INT@20:\n{logs_text}"
        );
    }

    let merged = exr_pixels(&frames.join("frame.exr"));
    let single_start = Instant::now();
    let single = single_render(work.path(), &settings, "single");
    let single_seconds = single_start.elapsed().as_secs_f64();
    let (relative, absolute) = differences(&merged, &single);
    report(&format!(
        "farm: {farm_seconds:.0} s from submission to merge; restarts per shard {restarts:?}; \
         stopped by the early SIGINT {} times, {leads:?} s before the time limit (asked: 20 s); \
         single render on 2 threads {single_seconds:.0} s; merge vs single render at {spp} spp: \
         max relative difference {relative:.2e}, max absolute {absolute:.2e}",
        leads.len()
    ));
    // Rounding only: both images add the same f32 samples, in another order and grouping.
    // One sample more or less would move a pixel's mean by about 1/spp of its value (> 2.5e-5
    // at the at most 40 000 spp used here); the rounding of sums of spp f32 terms stays near
    // √spp·2⁻²⁴ (≈ 1e-5 at 40 000 spp).
    assert!(
        relative < 1e-4,
        "merged frame differs from the single render by {relative:e} (relative)"
    );

    // --- 2. A shard that never runs (cancelled while held): the merge fails loudly instead
    // of waiting forever, and the command it prints finishes the frame.
    let small = strings(&[
        "--width",
        "24",
        "--height",
        "16",
        "--max-depth",
        "2",
        "--seed",
        "5",
        "--spp",
        "12",
    ]);
    let lost = work.path().join("lost");
    let lost_logs = lost.join("logs");
    let held = |extra: &[&str]| {
        let output = cluster
            .command(submit_script())
            .arg(scene())
            .args([
                "--shards",
                "2",
                "--cpus-per-task",
                "1",
                "--sbatch-option=--hold",
            ])
            .args(["--out".as_ref(), lost.join("frame.png").as_os_str()])
            .args(["--exr".as_ref(), lost.join("frame.exr").as_os_str()])
            .args(extra)
            .args(&small)
            .current_dir(work.path())
            .output()
            .unwrap();
        submitted_jobs(&output)
    };
    let release = |ids: &[String]| {
        for id in ids {
            let out = cluster.run("scontrol", &["release", id]);
            assert!(out.status.success(), "release {id}: {}", text(&out.stderr));
        }
    };
    let (array, merge) = held(&[]);
    let array = array.unwrap();
    let cancel = cluster.run("scancel", &[&format!("{array}_1")]);
    assert!(cancel.status.success(), "{}", text(&cancel.stderr));
    release(&[format!("{array}_0"), merge.clone()]);
    let state = cluster.wait_until_ended(&merge, Duration::from_secs(120), &lost_logs);
    let merge_log = fs::read_to_string(lost_logs.join("frame.merge.log")).unwrap();
    assert_eq!(state, "FAILED", "{merge_log}");
    assert!(
        merge_log.contains("shard(s) 1 of 0..1 did not finish")
            && merge_log.contains("never started"),
        "{merge_log}"
    );
    let again = merge_log
        .lines()
        .skip_while(|line| !line.contains("To finish it"))
        .nth(1)
        .and_then(|line| line.split_once("] "))
        .map(|(_, command)| command.trim().to_string())
        .unwrap_or_else(|| panic!("no command to finish the frame in:\n{merge_log}"));
    assert!(again.ends_with("--continue"), "{again}");
    let continued = cluster
        .command("bash")
        .args(["-c", &again])
        .output()
        .unwrap();
    let (array, merge) = submitted_jobs(&continued);
    assert!(
        text(&continued.stdout).contains("tasks 1 of 0..1"),
        "only the lost shard is submitted again:\n{}",
        text(&continued.stdout)
    );
    release(&[format!("{}_1", array.unwrap()), merge.clone()]);
    let state = cluster.wait_until_ended(&merge, Duration::from_secs(120), &lost_logs);
    assert_eq!(state, "COMPLETED", "{}", folder_contents(&lost_logs));
    let (relative, _) = differences(
        &exr_pixels(&lost.join("frame.exr")),
        &single_render(work.path(), &small, "small"),
    );
    assert!(relative < 1e-5, "{relative:e}");

    // --- 3. The same with --allow-missing: the merge takes what is there, says what is
    // missing, and succeeds.
    fs::remove_dir_all(&lost).unwrap();
    let (array, merge) = held(&["--allow-missing"]);
    let array = array.unwrap();
    let cancel = cluster.run("scancel", &[&format!("{array}_1")]);
    assert!(cancel.status.success(), "{}", text(&cancel.stderr));
    release(&[format!("{array}_0"), merge.clone()]);
    let state = cluster.wait_until_ended(&merge, Duration::from_secs(120), &lost_logs);
    let merge_log = fs::read_to_string(lost_logs.join("frame.merge.log")).unwrap();
    assert_eq!(state, "COMPLETED", "{merge_log}");
    assert!(
        merge_log.contains("missing") && merge_log.contains("6 spp from 1 of 2 shards"),
        "{merge_log}"
    );
    report(&format!(
        "the whole real-Slurm test took {:.0} s",
        started.elapsed().as_secs_f64()
    ));
}

// ------------------------------------------------------------------ submit.sh's usage errors

fn submit(dir: &Path, args: &[&str]) -> Output {
    Command::new(submit_script())
        .args(args)
        .current_dir(dir)
        .env("REALCAM", REALCAM)
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

#[test]
fn submit_refuses_bad_arguments_with_a_clear_message() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene();
    let scene = scene.to_str().unwrap();
    let cases: [(&[&str], &str); 13] = [
        (&[], "missing SCENE"),
        (&["--shards", "2"], "the first argument is the SCENE"),
        (&[scene, "--out", "f.png"], "missing --shards"),
        (
            &[scene, "--shards", "0", "--out", "f.png"],
            "positive whole number",
        ),
        (&[scene, "--shards", "2"], "missing --out"),
        (
            &[scene, "--shards", "2", "--out", "f.exr"],
            "must name a .png",
        ),
        (
            &["nope.glb", "--shards", "2", "--out", "f.png"],
            "nope.glb: no such scene",
        ),
        (
            &[scene, "--shards", "2", "--out", "f.png", "--shard", "1/2"],
            "--shard is set by the farm",
        ),
        (
            &[
                scene,
                "--shards",
                "2",
                "--out",
                "f.png",
                "--focus-sweep",
                "1:2:3",
            ],
            "does not fit a sharded frame",
        ),
        (
            &[scene, "--shards", "2", "--out", "f.png", "--zoom-sweep"],
            "--zoom-sweep does not fit a sharded frame",
        ),
        (
            &[
                scene,
                "--shards",
                "2",
                "--out",
                "f.png",
                "--f-number-sweep",
                "2:4:2",
            ],
            "--f-number-sweep does not fit a sharded frame",
        ),
        (
            &[
                scene, "--shards", "2", "--out", "f.png", "--lens", "a", "--lens", "b",
            ],
            "--lens is given 2 times",
        ),
        (
            &[scene, "--shards", "2", "--out", "f.png", "--time"],
            "--time needs a value",
        ),
    ];
    for (args, phrase) in cases {
        let output = submit(dir.path(), args);
        let stderr = text(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(phrase), "{args:?}: {stderr}");
    }
    // Nothing was created for the refused submissions.
    assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn submit_prints_absolute_paths_and_refuses_to_clobber_an_earlier_frame() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene();
    let scene = scene.to_str().unwrap();
    let args = [
        scene,
        "--shards",
        "3",
        "--out",
        "frames/f.png",
        "--time",
        "02:00:00",
        "--stop-before",
        "300",
        "--spp",
        "64",
        "--dry-run",
    ];
    let output = submit(dir.path(), &args);
    let stdout = text(&output.stdout);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let frame = dir.path().join("frames/f.png");
    for expected in [
        "--array=0-2".to_string(),
        "--signal=INT@300".to_string(),
        "--time=02:00:00".to_string(),
        "--open-mode=append".to_string(),
        "--requeue".to_string(),
        "--dependency=afterany:ARRAY_JOB".to_string(),
        format!(
            "--output={}/frames/logs/f.shard-%a.log",
            dir.path().display()
        ),
        frame.display().to_string(),
    ] {
        assert!(stdout.contains(&expected), "{expected} not in:\n{stdout}");
    }
    assert!(
        !dir.path().join("frames").exists(),
        "a dry run creates nothing"
    );

    // Partials of an earlier submission are kept only when asked (--continue), and then only
    // the shards without a partial are submitted.
    fs::create_dir_all(dir.path().join("frames")).unwrap();
    fs::write(dir.path().join("frames/f.shard-1-of-3.exr"), b"").unwrap();
    let output = submit(dir.path(), &args);
    assert_eq!(output.status.code(), Some(2));
    assert!(
        text(&output.stderr).contains("--continue"),
        "{}",
        text(&output.stderr)
    );
    let mut continued = args.to_vec();
    continued.push("--continue");
    let output = submit(dir.path(), &continued);
    assert!(output.status.success(), "{}", text(&output.stderr));
    assert!(
        text(&output.stdout).contains("--array=0,2"),
        "{}",
        text(&output.stdout)
    );
}
