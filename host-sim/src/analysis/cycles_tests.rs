//! Tests of `cycles`: the QEMU flags, the target directory, the timing table, the trace.
use super::*;

#[test]
fn qemu_flags_follow_its_version() {
    let flags = |v: &str| one_insn_per_tb_flags(v).unwrap();
    let debian = "QEMU emulator version 7.2.22 (Debian 1:7.2+dfsg-7+deb12u18+b2)\nCopyright";
    assert_eq!(flags(debian), ["-singlestep"]);
    assert_eq!(flags("QEMU emulator version 8.0.5"), ["-singlestep"]);
    let new = ["-accel", "tcg,one-insn-per-tb=on"];
    assert_eq!(flags("QEMU emulator version 8.1.0"), new);
    assert_eq!(flags("QEMU emulator version 9.2.1 (v9.2.1)"), new);
    assert_eq!(
        flags("QEMU emulator version 10.0.2 (Debian 1:10.0.2+ds-2)"),
        new
    );
    assert!(one_insn_per_tb_flags("qemu-system-arm: command not found").is_err());
}

#[test]
fn the_target_directory_follows_cargo_target_dir() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let manifest = root.join("examples/qemu-m4f/Cargo.toml");
    let expected = std::env::var_os("CARGO_TARGET_DIR")
        .map_or_else(|| root.join("examples/qemu-m4f/target"), PathBuf::from);
    assert_eq!(target_dir(root, &manifest).unwrap(), expected);
    let moved = run(
        metadata(root, &manifest).env("CARGO_TARGET_DIR", "/tmp/elsewhere"),
        "cargo metadata",
    )
    .unwrap();
    assert!(
        moved.contains("\"target_directory\":\"/tmp/elsewhere\""),
        "{moved}"
    );
}

fn insn(m: &str, o: &str) -> Insn {
    Insn {
        mnemonic: m.into(),
        operands: o.into(),
    }
}

#[test]
fn timing_table() {
    assert_eq!(cycles(&insn("adds", "r0, r1"), false), 1);
    assert_eq!(cycles(&insn("ldr", "r0, [r1]"), false), 2);
    assert_eq!(cycles(&insn("push", "{r4, r5, r6, r7, lr}"), false), 6);
    assert_eq!(cycles(&insn("pop", "{r4-r7, pc}"), true), 1 + 5 + 2);
    assert_eq!(cycles(&insn("vpush", "{d8, d9}"), false), 3);
    assert_eq!(cycles(&insn("vmla.f32", "s0, s1, s2"), false), 3);
    assert_eq!(cycles(&insn("vdiv.f32", "s0, s1, s2"), false), 14);
    assert_eq!(cycles(&insn("vldr", "s0, [r0]"), false), 2);
    assert_eq!(cycles(&insn("bne.w", "0x800"), true), 3);
    assert_eq!(cycles(&insn("bne", "0x800"), false), 1);
    assert_eq!(cycles(&insn("bl", "0x800"), true), 3);
    assert_eq!(cycles(&insn("tbb", "[pc, r0]"), true), 6);
    assert_eq!(register_count("{s16-s23}"), 8);
}

#[test]
fn trace_lines_parse() {
    let t = "Trace 0: 0x7f [00800408/00002d80/00000110/ff000201] bench_begin_step\n";
    assert_eq!(read_trace(t), vec![(0x2d80, "bench_begin_step")]);
}
