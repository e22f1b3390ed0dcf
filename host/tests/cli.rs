//! End-to-end runs of the `host` binary: device reporting, CPU fallback, forced GPU failure.

use std::process::Command;

fn host() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host"))
}

/// Environment that hides every Vulkan driver from the loader.
fn without_vulkan(cmd: &mut Command) -> &mut Command {
    cmd.env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
}

#[test]
fn default_run_reports_the_device_and_a_less_biased_jackknife() {
    let out = host().args(["--count", "200000"]).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("backend: gpu"), "{stdout}");
    let bias = |label: &str| -> f64 {
        let line = stdout.lines().find(|l| l.contains(label)).unwrap();
        line.split("bias ").nth(1).unwrap().trim().parse().unwrap()
    };
    // tau = 2, sigma = 1: the naive mean is exp(-2 + 1/4), bias +0.0385; the jackknife is unbiased
    // for normal inputs. 200k pairs give a standard error of about 0.00025 for the jackknife.
    assert!(bias("jackknife").abs() < 0.0015, "{stdout}");
    assert!((bias("naive") - 0.0385).abs() < 0.0015, "{stdout}");
}

#[test]
fn cpu_and_gpu_print_identical_numbers() {
    let run = |backend: &str| {
        let out = host()
            .args(["--count", "100000", "--seed", "9", "--backend", backend])
            .output()
            .unwrap();
        assert!(out.status.success());
        // Drop the backend line and the timing; everything else must match exactly.
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .skip(1)
            .map(|l| l.split(": kernel time").next().unwrap().to_string())
            .collect::<Vec<_>>()
    };
    assert_eq!(run("gpu"), run("cpu"));
}

#[test]
fn without_a_driver_auto_falls_back_to_cpu_with_a_warning() {
    let out = without_vulkan(&mut host())
        .args(["--count", "1000"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stderr}");
    assert!(stdout.contains("backend: cpu"), "{stdout}");
    let warnings: Vec<_> = stderr
        .lines()
        .filter(|l| l.starts_with("warning:"))
        .collect();
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(
        warnings[0].contains("falling back to the CPU backend"),
        "{stderr}"
    );
}

#[test]
fn without_a_driver_forced_gpu_fails_clearly() {
    let out = without_vulkan(&mut host())
        .args(["--backend", "gpu", "--count", "1000"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(stderr.contains("--backend gpu"), "{stderr}");
    assert!(stderr.contains("mesa-vulkan-drivers"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn bad_flags_get_helpful_errors() {
    for args in [
        &["--count", "0"][..],
        &["--sigma", "-1"],
        &["--backend", "tpu"],
        &["--tau", "nan"],
    ] {
        let out = host().args(args).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(
            stderr.contains(args[0]) || stderr.contains(args[1]),
            "{args:?}: {stderr}"
        );
    }
}
