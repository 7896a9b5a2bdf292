use super::*;

fn me() -> Holder {
    Holder::me("/dev/pts/99").expect("/proc knows this process")
}

/// A lock with fixed fields, so that what a corruption does is known.
fn sample() -> Holder {
    Holder {
        pid: 4242,
        start: 987654,
        exe: PathBuf::from("/usr/local/bin/axisctl"),
        what: "--link slcan:/dev/ttyACM0 dashboard".into(),
        device: "/dev/ttyACM0".into(),
        halting: false,
    }
}

#[test]
fn a_lock_reads_back_as_written() {
    let h = me();
    assert_eq!(Holder::parse(&h.to_text()), Ok(h.clone()));
    assert_eq!(h.pid, std::process::id());
    assert!(!h.halting, "only a takeover marks itself");
    assert!(h.to_text().starts_with("axisctl-lock 1\npid "), "{}", h.to_text());
    let halt = Holder { halting: true, ..sample() };
    assert!(halt.to_text().ends_with("\nrole halt\n"), "{}", halt.to_text());
    assert_eq!(Holder::parse(&halt.to_text()), Ok(halt));
    assert!(!sample().to_text().contains("role"));
    let other_role = sample().to_text() + "role dashboard\n";
    assert_eq!(Holder::parse(&other_role), Ok(sample()));
}

#[test]
fn garbage_never_parses_and_never_panics() {
    for text in [
        "",
        "\n\n",
        "pid 12\nstart 3\nexe /bin/axisctl\n",
        "axisctl-lock 1\n",
        "axisctl-lock 1\npid\nstart\nexe\n",
        "axisctl-lock 1\npid -5\nstart 3\nexe /bin/axisctl\n",
        "axisctl-lock 1\npid 0\nstart 3\nexe /bin/axisctl\n",
        "axisctl-lock 1\npid 2147483648\nstart 3\nexe /bin/axisctl\n",
        "axisctl-lock 1\npid 99999999999\nstart 3\nexe /bin/axisctl\n",
        "axisctl-lock 1\npid 12\nstart x\nexe /bin/axisctl\n",
        "axisctl-lock 1\npid 12\nstart 3\nexe relative/axisctl\n",
        "axisctl-lock 1\npid 12\nstart 3\n",
        "axisctl-lock 1\nstart 3\nexe /bin/axisctl\n",
        "\u{0}\u{ffff}))(( ",
    ] {
        assert!(Holder::parse(text).is_err(), "{text:?} parsed");
    }
    // The largest PID that is not a process group.
    let max = "axisctl-lock 1\npid 2147483647\nstart 3\nexe /bin/axisctl\n";
    assert_eq!(Holder::parse(max).map(|h| h.pid), Ok(i32::MAX as u32));

    let good = sample().to_text();
    let line_of = |i: usize| good[..i].matches('\n').count();
    let exe_value = good.find("\nexe /").unwrap() + 5;
    // Every prefix: whole up to the exe's first character, it reads with
    // the fields cut short; shorter, it does not read.
    for cut in 0..good.len() {
        match Holder::parse(&good[..cut]) {
            Ok(h) => {
                assert!(cut > exe_value, "{:?} parsed", &good[..cut]);
                assert_eq!((h.pid, h.start), (4242, 987654));
                assert!(sample().exe.to_str().unwrap().starts_with(h.exe.to_str().unwrap()), "{h:?}");
                assert!(sample().what.starts_with(&h.what) && sample().device.starts_with(&h.device), "{h:?}");
            }
            Err(_) => assert!(cut <= exe_value, "{:?} did not parse", &good[..cut]),
        }
    }
    // Every single-byte corruption: the magic line, a key, the separator or
    // the exe's leading `/` breaks it; a newline in a number cuts it short;
    // anything else in a number breaks it; the rest leaves pid and start whole.
    let bytes = good.as_bytes();
    for i in 0..bytes.len() {
        for b in [0u8, b'\n', b' ', b')', 0xff] {
            if bytes[i] == b {
                continue;
            }
            let mut v = bytes.to_vec();
            v[i] = b;
            let text = String::from_utf8_lossy(&v).into_owned();
            let got = Holder::parse(&text);
            let line = line_of(i);
            let line_start = good[..i].rfind('\n').map_or(0, |n| n + 1);
            let key_len = good[line_start..].find(' ').unwrap_or(0);
            let in_key = i <= line_start + key_len;
            let at_line_end = bytes[i] == b'\n';
            let expect_ok = match line {
                0 => false,
                // pid, start: only a newline inside the digits, after the first.
                1 | 2 => b == b'\n' && !in_key && i > line_start + key_len + 1 && !at_line_end,
                // exe: its key, separator and leading `/` are needed.
                3 => i > line_start + key_len + 1,
                _ => {
                    // what, device: a broken key or a joined line costs nothing needed.
                    true
                }
            };
            match &got {
                Ok(h) => {
                    assert!(expect_ok, "corrupting byte {i} to {b:#x} parsed: {text:?} -> {h:?}");
                    if line != 1 {
                        assert_eq!(h.pid, 4242, "{text:?}");
                    }
                    if line != 2 {
                        assert_eq!(h.start, 987654, "{text:?}");
                    }
                    assert!(h.exe.is_absolute());
                }
                Err(_) => assert!(!expect_ok, "corrupting byte {i} to {b:#x} did not parse: {text:?}"),
            }
        }
    }
}

#[test]
fn stat_fields_are_counted_after_the_last_parenthesis() {
    let line = "42 (a) b (c)) S 1 42 42 0 -1 4194560 100 0 0 0 1 2 0 0 20 0 1 0 987654 1000 10";
    assert_eq!(stat_field(line, 3), Some("S"));
    assert_eq!(stat_field(line, 22), Some("987654"));
    assert_eq!(stat_field("no parenthesis", 22), None);
    assert_eq!(stat_field("1 (x) S", 22), None);
    assert_eq!(stat_field("1 (x) S", 1), None);
}

#[test]
fn this_very_program_counts_as_axisctl_and_a_forged_exe_is_caught() {
    // The test binary is not named axisctl, yet it is "this very program".
    assert_eq!(me().check(), Verdict::Axisctl);
    let forged = Holder { exe: PathBuf::from("/usr/local/bin/axisctl"), ..me() };
    assert!(matches!(forged.check(), Verdict::NotAxisctl(why) if why.contains("not the /usr/local/bin/axisctl")));
}

#[test]
fn a_live_process_that_is_not_axisctl_is_never_signalled() {
    let mut sleep = std::process::Command::new("sleep").arg("30").spawn().unwrap();
    let pid = sleep.id();
    let start = proc_start(pid).unwrap().unwrap();
    let exe = without_deleted(&std::fs::read_link(format!("/proc/{pid}/exe")).unwrap());
    // Honest (it says it runs sleep) and forged (it claims axisctl): both refused.
    for exe in [exe, PathBuf::from("/usr/bin/axisctl")] {
        let h = Holder { pid, start, exe, what: "60".into(), device: "/dev/x".into(), halting: false };
        assert!(matches!(h.check(), Verdict::NotAxisctl(_)), "{:?}", h.check());
        assert!(!h.is_gone());
        assert!(matches!(h.terminate(), Err(TerminateError::NotAxisctl(_))));
    }
    assert!(sleep.try_wait().unwrap().is_none(), "sleep was signalled");
    sleep.kill().unwrap();
    sleep.wait().unwrap();
}

#[test]
fn a_dead_or_reused_pid_is_stale() {
    let mut child = std::process::Command::new("true").spawn().unwrap();
    let pid = child.id();
    child.wait().unwrap();
    let dead = Holder { pid, start: 1, exe: PathBuf::from("/bin/true"), ..sample() };
    assert_eq!(dead.check(), Verdict::Stale);
    assert!(dead.is_gone());
    assert!(matches!(dead.terminate(), Err(TerminateError::Gone)));
    let reused = Holder { start: me().start + 1, ..me() };
    assert_eq!(reused.check(), Verdict::Stale);
    assert!(reused.is_gone());
    assert!(!me().is_gone());
    assert!(matches!(me().terminate(), Err(TerminateError::Itself)), "never signals itself");
}

/// A copy of this very program that has exited but is not reaped yet: a
/// zombie holds no port, so it is gone (stale), never signalled, and a
/// wait for it ends at once.
#[test]
fn a_zombie_holder_is_gone_and_is_never_signalled() {
    let exe = std::env::current_exe().unwrap();
    let mut child = std::process::Command::new(&exe)
        .args(["--list", "--exact", "no such test"])
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let pid = child.id();
    let start = proc_start(pid).unwrap().unwrap();
    let h = Holder { pid, start, exe: without_deleted(&exe), ..sample() };
    let deadline = Instant::now() + Duration::from_secs(30);
    while !is_zombie(pid) {
        assert!(Instant::now() < deadline, "the child never exited");
        std::thread::sleep(Duration::from_millis(5));
    }
    assert_eq!(proc_start(pid).unwrap(), Some(start), "still there, unreaped");
    assert_eq!(h.check(), Verdict::Stale);
    assert!(h.is_gone());
    let t0 = Instant::now();
    assert!(h.wait_gone(Duration::from_secs(5)));
    assert!(t0.elapsed() < Duration::from_secs(1), "waited {:?} for a zombie", t0.elapsed());
    assert!(matches!(h.terminate(), Err(TerminateError::Gone)));
    assert!(child.wait().unwrap().success());
}

const CHILD: &str = "AXISCTL_LOCK_TEST_CHILD";

/// The holder of `a_live_axisctl_holder_is_signalled_and_ends`: a copy of
/// this very program that waits to be signalled. In a plain test run it
/// returns at once.
#[test]
fn a_child_that_waits_to_be_signalled() {
    if std::env::var_os(CHILD).is_some() {
        std::thread::sleep(Duration::from_secs(60));
    }
}

/// A live copy of this very program is axisctl, so `terminate` signals it,
/// and it ends by the SIGTERM (the other tests only see refusals).
#[test]
fn a_live_axisctl_holder_is_signalled_and_ends() {
    use std::os::unix::process::ExitStatusExt;
    let exe = std::env::current_exe().unwrap();
    let mut child = std::process::Command::new(&exe)
        .args(["--exact", "link::lock::tests::a_child_that_waits_to_be_signalled"])
        .env(CHILD, "1")
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let pid = child.id();
    let h = Holder { pid, start: proc_start(pid).unwrap().unwrap(), exe: without_deleted(&exe), ..sample() };
    assert_eq!(h.check(), Verdict::Axisctl);
    h.terminate().expect("signalled");
    let deadline = Instant::now() + Duration::from_secs(30);
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if Instant::now() > deadline {
            child.kill().unwrap();
            panic!("the holder was not signalled: {:?}", child.wait().unwrap());
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    assert_eq!(status.signal(), Some(libc::SIGTERM), "{status:?}");
    assert!(h.is_gone());
    assert!(matches!(h.terminate(), Err(TerminateError::Gone)), "an ended holder is not signalled again");
}

#[test]
fn a_wait_for_a_live_process_runs_to_its_bound() {
    let t0 = Instant::now();
    assert!(!me().wait_gone(Duration::from_millis(50)));
    assert!(t0.elapsed() >= Duration::from_millis(50));
}

#[test]
fn lock_names_escape_the_path() {
    let dir = Path::new("/run/user/1/axisctl");
    assert_eq!(lock_path_in(dir, "/dev/pts/3"), dir.join("%2Fdev%2Fpts%2F3.lock"));
    assert_ne!(lock_path_in(dir, "/dev/a%2Fb"), lock_path_in(dir, "/dev/a/b"));
}

#[test]
fn a_lock_is_written_replaces_a_stale_one_and_goes_with_its_holder() {
    let dir = tempfile::tempdir().unwrap();
    let dirs = [dir.path().to_path_buf()];
    let device = "/dev/axisctl-lock-test";
    let path = lock_path_in(dir.path(), device);
    std::fs::write(&path, "garbage from a crashed run").unwrap();
    assert!(matches!(find_in(&dirs, device), Found::Unreadable(_)));
    let lock = acquire_in(&dirs, device).expect("written");
    assert_eq!(lock.paths(), std::slice::from_ref(&path));
    let Found::Holder(h, Verdict::Axisctl) = find_in(&dirs, device) else { panic!("{:?}", find_in(&dirs, device)) };
    assert_eq!((h.pid, h.device.as_str()), (std::process::id(), device));
    drop(lock);
    assert_eq!(find_in(&dirs, device), Found::Nothing, "removed on drop");
    // A lock that names someone else by then is theirs: left alone.
    let lock = acquire_in(&dirs, device).unwrap();
    let other = Holder { pid: 1, ..h };
    std::fs::write(&path, other.to_text()).unwrap();
    drop(lock);
    assert!(matches!(find_in(&dirs, device), Found::Holder(h, _) if h == other));
    let leftovers: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(leftovers.len(), 1, "{leftovers:?}");
}

#[test]
fn among_several_locks_the_live_axisctl_holder_wins() {
    let dirs: Vec<_> = (0..4).map(|_| tempfile::tempdir().unwrap()).collect();
    let paths: Vec<PathBuf> = dirs.iter().map(|d| d.path().to_path_buf()).collect();
    let device = "/dev/axisctl-rank-test";
    let mut gone = std::process::Command::new("true").spawn().unwrap();
    let dead = Holder { pid: gone.id(), start: 1, ..sample() };
    gone.wait().unwrap();
    let forged = Holder { exe: PathBuf::from("/usr/local/bin/axisctl"), ..me() };
    std::fs::write(lock_path_in(&paths[0], device), "garbage").unwrap();
    std::fs::write(lock_path_in(&paths[1], device), dead.to_text()).unwrap();
    assert!(matches!(find_in(&paths[..2], device), Found::Holder(h, Verdict::Stale) if h == dead));
    std::fs::write(lock_path_in(&paths[2], device), forged.to_text()).unwrap();
    assert!(matches!(find_in(&paths[..3], device), Found::Holder(_, Verdict::NotAxisctl(_))));
    let _lock = acquire_in(&paths[3..], device).unwrap();
    for order in [[0, 1, 2, 3], [3, 2, 1, 0], [2, 3, 0, 1]] {
        let these: Vec<PathBuf> = order.iter().map(|&i| paths[i].clone()).collect();
        assert!(matches!(find_in(&these, device), Found::Holder(h, Verdict::Axisctl) if h.pid == std::process::id()));
    }
    assert!(matches!(find_in(&paths[..1], device), Found::Unreadable(_)));
    assert_eq!(find_in(&[], device), Found::Nothing);
}

/// Between two locks that tell as much, the first place searched (the
/// runtime directory comes first) names the holder, whatever the second says.
#[test]
fn between_equally_telling_locks_the_first_place_wins() {
    let dirs: Vec<_> = (0..2).map(|_| tempfile::tempdir().unwrap()).collect();
    let paths: Vec<PathBuf> = dirs.iter().map(|d| d.path().to_path_buf()).collect();
    let device = "/dev/axisctl-tie-test";
    let mut gone = Vec::new();
    for _ in 0..2 {
        let mut child = std::process::Command::new("true").spawn().unwrap();
        gone.push(Holder { pid: child.id(), start: 1, ..sample() });
        child.wait().unwrap();
    }
    assert_ne!(gone[0].pid, gone[1].pid);
    for (dir, h) in paths.iter().zip(&gone) {
        std::fs::write(lock_path_in(dir, device), h.to_text()).unwrap();
    }
    for (order, first) in [([0, 1], 0), ([1, 0], 1)] {
        let these: Vec<PathBuf> = order.iter().map(|&i| paths[i].clone()).collect();
        assert_eq!(find_in(&these, device), Found::Holder(gone[first].clone(), Verdict::Stale), "{order:?}");
    }
}

// ---- the directories ----

fn env_in(root: &Path) -> dir::Env {
    dir::Env {
        over: None,
        runtime: None,
        run_user: root.join("run-user"),
        temp: root.join("tmp"),
        tmp: root.join("slash-tmp"),
        // SAFETY: getuid cannot fail.
        uid: unsafe { libc::getuid() },
    }
}

fn mkdir(path: &Path, mode: u32) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::create_dir_all(path).unwrap();
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).unwrap();
}

static NOTICES: std::sync::Mutex<Vec<String>> = std::sync::Mutex::new(Vec::new());

fn notices_about(dir: &Path) -> Vec<String> {
    let dir = dir.display().to_string();
    NOTICES.lock().unwrap().iter().filter(|n| n.contains(&format!("directory {dir} "))).cloned().collect()
}

/// A directory someone else made first (open to all, a symlink to a
/// directory of ours, one that belongs to another user) is never used: a
/// private one beside it is, the same on every open, said once, and a
/// halt finds the lock there.
#[test]
fn a_lock_directory_that_is_not_private_is_never_used() {
    on_notice(|text| NOTICES.lock().unwrap().push(text.to_string()));
    // SAFETY: getuid cannot fail.
    let root_runs = unsafe { libc::getuid() } == 0;
    for case in ["open to all", "symlink", "another user", "not a directory"] {
        if case == "another user" && !root_runs {
            continue;
        }
        let root = tempfile::tempdir().unwrap();
        let env = env_in(root.path());
        mkdir(&env.temp, 0o1777);
        let planted = env.temp.join(format!("axisctl-{}", env.uid));
        let elsewhere = root.path().join("elsewhere");
        mkdir(&elsewhere, 0o700);
        match case {
            "open to all" => mkdir(&planted, 0o777),
            "symlink" => std::os::unix::fs::symlink(&elsewhere, &planted).unwrap(),
            "another user" => {
                mkdir(&planted, 0o700);
                std::os::unix::fs::chown(&planted, Some(65534), None).unwrap();
            }
            _ => std::fs::write(&planted, "").unwrap(),
        }
        // A decoy beside it that is not ours either.
        mkdir(&env.temp.join(format!("axisctl-{}-aaaaaa", env.uid)), 0o777);
        let device = format!("/dev/axisctl-planted-{}", case.replace(' ', "-"));
        let lock = acquire_with(&env, &device).expect("a lock is written");
        assert_eq!(lock.paths().len(), 1, "{case}: {:?}", lock.paths());
        let written = lock.paths()[0].clone();
        let used = written.parent().unwrap().to_path_buf();
        assert_ne!(used, planted, "{case}");
        assert!(used.starts_with(&env.temp), "{case}: {used:?}");
        assert!(used.file_name().unwrap().to_str().unwrap().starts_with(&format!("axisctl-{}-", env.uid)));
        assert_eq!(dir::private(&used, env.uid), Ok(()), "{case}");
        assert!(std::fs::read_dir(&elsewhere).unwrap().next().is_none(), "{case}: written through the symlink");
        // The next open uses the same directory, and nothing more is said.
        let again = acquire_with(&env, "/dev/axisctl-planted-again").unwrap();
        assert_eq!(again.paths()[0].parent().unwrap(), used, "{case}");
        let said = notices_about(&planted);
        assert_eq!(said.len(), 1, "{case}: {said:?}");
        assert!(said[0].contains("is not used (") && said[0].contains(&used.display().to_string()), "{said:?}");
        // A halt, with or without TMPDIR, finds it.
        let halt = dir::Env { temp: root.path().join("other-tmp"), tmp: env.temp.clone(), ..env.clone() };
        for e in [&env, &halt] {
            assert!(
                matches!(find_with(e, &device), Found::Holder(h, Verdict::Axisctl) if h.pid == std::process::id()),
                "{case}: {:?}",
                find_with(e, &device)
            );
        }
        // A lock planted in the refused directory is never read.
        if case == "open to all" {
            drop(lock);
            let forged = Holder { device: device.clone(), ..me() };
            std::fs::write(lock_path_in(&planted, &device), forged.to_text()).unwrap();
            assert_eq!(find_with(&env, &device), Found::Nothing);
        }
    }
}

#[test]
fn a_private_directory_is_exactly_a_0700_directory_of_this_user() {
    let root = tempfile::tempdir().unwrap();
    // SAFETY: getuid cannot fail.
    let uid = unsafe { libc::getuid() };
    let d = root.path().join("d");
    mkdir(&d, 0o700);
    assert_eq!(dir::private(&d, uid), Ok(()));
    assert_eq!(dir::private(&d, uid + 1), Err(format!("it belongs to UID {uid}")));
    for (mode, text) in [(0o755, "0755"), (0o701, "0701"), (0o710, "0710"), (0o1700, "1700"), (0o500, "0500")] {
        mkdir(&d, mode);
        assert_eq!(dir::private(&d, uid), Err(format!("its mode is {text}, not 0700")));
    }
    mkdir(&d, 0o700);
    let link = root.path().join("l");
    std::os::unix::fs::symlink(&d, &link).unwrap();
    assert_eq!(dir::private(&link, uid), Err("it is a symbolic link".into()));
    assert!(dir::private(&root.path().join("none"), uid).is_err());
}

/// The places written and looked in, with and without XDG_RUNTIME_DIR: a
/// holder of either kind is found by a halt of either kind.
#[test]
fn a_halt_finds_a_holder_whatever_either_environment() {
    let root = tempfile::tempdir().unwrap();
    let base = env_in(root.path());
    mkdir(&base.temp, 0o700);
    let xdg = root.path().join("xdg");
    mkdir(&xdg, 0o700);
    let with_xdg = dir::Env { runtime: Some(xdg.clone()), ..base.clone() };
    // No /run/user/UID: only the temporary directory.
    let device = "/dev/axisctl-env-test";
    let lock = acquire_with(&base, device).unwrap();
    assert_eq!(lock.paths(), [lock_path_in(&base.temp.join(format!("axisctl-{}", base.uid)), device)]);
    assert!(matches!(find_with(&with_xdg, device), Found::Holder(_, Verdict::Axisctl)));
    drop(lock);
    // With XDG_RUNTIME_DIR: both, the runtime one first.
    let lock = acquire_with(&with_xdg, device).unwrap();
    assert_eq!(lock.paths().len(), 2, "{:?}", lock.paths());
    assert!(lock.paths()[0].starts_with(xdg.join("axisctl")), "{:?}", lock.paths());
    assert!(lock.paths()[1].starts_with(&base.temp), "{:?}", lock.paths());
    // A halt without XDG_RUNTIME_DIR, and one whose TMPDIR is not the
    // holder's: one finds the temporary lock, the other the runtime one
    // under /run/user/UID (here the same directory as the holder's XDG one).
    let other_tmp = root.path().join("other-tmp");
    let halts =
        [base.clone(), dir::Env { runtime: None, run_user: xdg.clone(), temp: other_tmp.clone(), ..base.clone() }];
    for e in &halts {
        assert!(matches!(find_with(e, device), Found::Holder(_, Verdict::Axisctl)), "{e:?}");
    }
    drop(lock);
    for e in &halts {
        assert_eq!(find_with(e, device), Found::Nothing, "both removed on drop");
    }
    // /run/user/UID is written when it is there and there is no XDG_RUNTIME_DIR.
    let with_run = dir::Env { run_user: xdg.clone(), ..base.clone() };
    let lock = acquire_with(&with_run, device).unwrap();
    assert!(lock.paths()[0].starts_with(xdg.join("axisctl")), "{:?}", lock.paths());
    assert_eq!(lock.paths().len(), 2);
    drop(lock);
    // A lock in the holder's /tmp is found by a halt whose TMPDIR is elsewhere.
    let lock = acquire_with(&base, device).unwrap();
    let halt = dir::Env { temp: other_tmp, tmp: base.temp.clone(), ..base.clone() };
    assert!(matches!(find_with(&halt, device), Found::Holder(_, Verdict::Axisctl)));
    drop(lock);
    // AXISCTL_LOCK_DIR is the one place.
    let only = root.path().join("only");
    let over = dir::Env { over: Some(only.clone()), ..with_xdg };
    let lock = acquire_with(&over, device).unwrap();
    assert_eq!(lock.paths(), [lock_path_in(&only, device)]);
    assert_eq!(find_with(&base, device), Found::Nothing);
    assert!(matches!(find_with(&over, device), Found::Holder(_, Verdict::Axisctl)));
}
