//! An instruction profile of the Cortex-M4 firmware under QEMU, per phase, function and source
//! line (`scripts/m4-profile.sh` runs it; docs/PORTING.md, "Profiling on the M4").
//!
//! QEMU's `-d in_asm,exec,nochain` log names every translated block once (`IN:` and its
//! instructions, one per line) and every block it executes (`Trace ...[flags/PC/...]`, block
//! chaining off so none is missed). Counting executions per block and spreading each over its
//! instructions gives an exact instruction count per address: `-icount` makes QEMU cut a block
//! short at times, and then the trace line carries the count it ran in the low 9 bits of its
//! last field. Counting starts at the first execution of the function named by `--from`
//! (the firmware's `profile_mark`, called before the tick `TETRADRILL_PROFILE_FROM` names), so
//! the profile covers the ticks from there on and not the start-up.
//!
//! The addresses are then resolved with `llvm-addr2line -f -C -i` (inlined frames included)
//! and added up by phase of the simulation step (contact search, candidate query, sort, drill,
//! servo), by innermost core function and by source line.
//!
//! Usage: `qemu-system-arm ... -d in_asm,exec,nochain -D /dev/stderr 2>&1 >/dev/null |
//! m4_profile --elf FIRMWARE [--from SYMBOL] [--top N]`. Exit status 2 for a bad flag or an
//! unreadable firmware, 1 when nothing was counted (the marker never ran).

use std::collections::HashMap;
use std::io::{BufRead, Write};
use std::process::{Command, ExitCode, Stdio};

/// Per block start address: the addresses of its instructions (the longest listing seen).
type Blocks = HashMap<u32, Vec<u32>>;

struct Args {
    elf: String,
    from: Option<String>,
    top: usize,
}

fn parse_args() -> Result<Args, String> {
    let mut elf = None;
    let mut from = Some("profile_mark".to_string());
    let mut top = 30;
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        match a.as_str() {
            "--elf" => elf = it.next(),
            "--from" => from = it.next().filter(|s| !s.is_empty()),
            "--all" => from = None,
            "--top" => {
                let v = it.next().unwrap_or_default();
                top = v
                    .parse()
                    .map_err(|_| format!("--top takes a whole number, not `{v}`"))?;
            }
            "-h" | "--help" => {
                return Err(
                    "usage: m4_profile --elf FIRMWARE [--from SYMBOL | --all] [--top N] \
                            < QEMU log"
                        .into(),
                )
            }
            other => return Err(format!("unknown argument `{other}`")),
        }
    }
    let elf = elf.ok_or("--elf FIRMWARE is required")?;
    if !std::path::Path::new(&elf).is_file() {
        return Err(format!("{elf}: no such firmware file"));
    }
    Ok(Args { elf, from, top })
}

/// Reads the log: block listings and executions; returns instructions per address.
fn count(input: impl BufRead, from: Option<&str>) -> HashMap<u32, u64> {
    let mut blocks: Blocks = HashMap::new();
    let mut hits: HashMap<u32, u64> = HashMap::new();
    let mut listing: Option<Vec<u32>> = None;
    let mut on = from.is_none();
    for line in input.lines().map_while(Result::ok) {
        if line.starts_with("IN:") {
            listing = Some(Vec::new());
            continue;
        }
        if let Some(l) = listing.as_mut() {
            if let Some(a) = line.strip_prefix("0x") {
                if let Some(addr) = a
                    .split(':')
                    .next()
                    .and_then(|h| u32::from_str_radix(h, 16).ok())
                {
                    l.push(addr);
                }
                continue;
            }
            let done = listing.take().unwrap_or_default();
            if let Some(&start) = done.first() {
                let e = blocks.entry(start).or_default();
                if done.len() > e.len() {
                    *e = done;
                }
            }
        }
        let Some(rest) = line.strip_prefix("Trace ") else {
            continue;
        };
        if !on {
            match from {
                Some(sym) if rest.contains(sym) => on = true,
                _ => continue,
            }
        }
        // `Trace 0: 0xHOST [xxxxxxxx/PC/FLAGS/CFLAGS] symbol`
        let Some(inside) = rest.split('[').nth(1).and_then(|s| s.split(']').next()) else {
            continue;
        };
        let f: Vec<&str> = inside.split('/').collect();
        let (Some(pc), Some(cflags)) = (
            f.get(1).and_then(|h| u32::from_str_radix(h, 16).ok()),
            f.get(3).and_then(|h| u32::from_str_radix(h, 16).ok()),
        ) else {
            continue;
        };
        let Some(insns) = blocks.get(&pc) else {
            continue;
        };
        let cut = (cflags & 0x1ff) as usize;
        let n = if cut != 0 {
            cut.min(insns.len())
        } else {
            insns.len()
        };
        for a in &insns[..n] {
            *hits.entry(*a).or_default() += 1;
        }
    }
    hits
}

/// The inlined frames of each address, innermost first: `(function, file:line)`.
fn resolve(elf: &str, addrs: &[u32]) -> Result<Vec<Vec<(String, String)>>, String> {
    let mut child = Command::new("llvm-addr2line")
        .args(["-e", elf, "-f", "-C", "-i", "-a"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot run llvm-addr2line (apt-get install llvm): {e}"))?;
    let mut stdin = child.stdin.take().ok_or("llvm-addr2line: no stdin")?;
    let list: String = addrs.iter().map(|a| format!("0x{a:x}\n")).collect();
    let writer = std::thread::spawn(move || stdin.write_all(list.as_bytes()));
    let out = child.wait_with_output().map_err(|e| e.to_string())?;
    let _ = writer.join();
    let text = String::from_utf8_lossy(&out.stdout);
    let mut frames: Vec<Vec<(String, String)>> = Vec::with_capacity(addrs.len());
    let mut lines = text.lines().peekable();
    while let Some(l) = lines.next() {
        if !l.starts_with("0x") {
            continue;
        }
        let mut f = Vec::new();
        while let Some(&next) = lines.peek() {
            if next.starts_with("0x") {
                break;
            }
            let func = lines.next().unwrap_or_default().to_string();
            let loc = lines.next().unwrap_or_default().to_string();
            f.push((func, loc));
        }
        frames.push(f);
    }
    if frames.len() != addrs.len() {
        return Err(format!(
            "llvm-addr2line answered {} addresses of {}",
            frames.len(),
            addrs.len()
        ));
    }
    Ok(frames)
}

/// The phase of the simulation step an address belongs to, from its inline chain.
fn phase(frames: &[(String, String)]) -> &'static str {
    let has = |s: &str| frames.iter().any(|(f, _)| f.contains(s));
    if has("hierarchy::nearest") {
        "contact search"
    } else if has("slice::sort") {
        "candidate sort"
    } else if has("query_box_once") || has("overlaps") {
        "candidate query"
    } else if has("tetradrill_core::drill") || has("hierarchy::ops") || has("hierarchy::visit") {
        "drill"
    } else if has("servo_force") {
        "servo force"
    } else if has("tetradrill_core") {
        "other core"
    } else {
        "runtime (libm, compiler builtins, output)"
    }
}

fn short(f: &str) -> String {
    // Drop the hash suffix and keep the last three path segments.
    let f = f.rsplit_once("::h").map_or(f, |(a, _)| a);
    let parts: Vec<&str> = f.split("::").collect();
    parts[parts.len().saturating_sub(3)..].join("::")
}

fn table(title: &str, total: u64, mut rows: Vec<(String, u64)>, top: usize) {
    rows.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    println!("\n== {title}");
    for (k, v) in rows.into_iter().take(top) {
        println!(
            "{v:>12} {:>5.1} %  {k}",
            100.0 * v as f64 / total.max(1) as f64
        );
    }
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("m4_profile: {e}");
            return ExitCode::from(2);
        }
    };
    let stdin = std::io::stdin();
    let hits = count(stdin.lock(), args.from.as_deref());
    let total: u64 = hits.values().sum();
    if total == 0 {
        eprintln!(
            "m4_profile: nothing counted (no `{}` in the execution log: was the firmware built \
             with TETRADRILL_PROFILE_FROM?)",
            args.from.as_deref().unwrap_or("?")
        );
        return ExitCode::from(1);
    }
    let mut addrs: Vec<u32> = hits.keys().copied().collect();
    addrs.sort_unstable();
    let frames = match resolve(&args.elf, &addrs) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("m4_profile: {e}");
            return ExitCode::from(2);
        }
    };
    let mut by_phase: HashMap<String, u64> = HashMap::new();
    let mut by_func: HashMap<String, u64> = HashMap::new();
    let mut by_line: HashMap<String, u64> = HashMap::new();
    for (a, f) in addrs.iter().zip(&frames) {
        let n = hits.get(a).copied().unwrap_or(0);
        *by_phase.entry(phase(f).to_string()).or_default() += n;
        let core = f.iter().find(|(func, _)| func.contains("tetradrill_core"));
        let (func, line) = core.or(f.first()).cloned().unwrap_or_default();
        *by_func.entry(short(&func)).or_default() += n;
        let line = line
            .split("/core-nostd/")
            .last()
            .unwrap_or(&line)
            .to_string();
        *by_line.entry(line).or_default() += n;
    }
    println!("instructions counted: {total}");
    table("phase", total, by_phase.into_iter().collect(), args.top);
    table(
        "innermost core function",
        total,
        by_func.into_iter().collect(),
        args.top,
    );
    table(
        "source line (innermost in core-nostd)",
        total,
        by_line.into_iter().collect(),
        args.top,
    );
    ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A log in QEMU 7.2's format, written by hand: two blocks, executions before and after
    /// the marker, one execution cut short by icount (count 1 in its cflags), and a second
    /// listing of a block that is shorter (a retranslation cut short) which must not shrink
    /// the block.
    #[test]
    fn counts_executions_from_the_marker_spread_over_each_block() {
        let log = "\
IN: main
0x00000100:  f005 fb3a  bl       #0x5a78
0x00000104:  2000       movs     r0, #0
0x00000106:  4770       bx       lr

IN: profile_mark
0x00000200:  4770       bx       lr

Trace 0: 0x7f00 [00800408/00000100/00000110/ff020200] main
Trace 0: 0x7f10 [00800408/00000200/00000110/ff020200] profile_mark
Trace 0: 0x7f00 [00800408/00000100/00000110/ff020200] main
Trace 0: 0x7f00 [00800408/00000100/00000110/ff020201] main
IN: main
0x00000100:  f005 fb3a  bl       #0x5a78

Trace 0: 0x7f00 [00800408/00000100/00000110/ff020200] main
";
        let hits = count(log.as_bytes(), Some("profile_mark"));
        // From the marker on: the marker (1 instruction), main in full twice, main cut to 1.
        assert_eq!(hits.get(&0x200), Some(&1));
        assert_eq!(hits.get(&0x100), Some(&3));
        assert_eq!(hits.get(&0x104), Some(&2));
        assert_eq!(hits.get(&0x106), Some(&2));
        assert_eq!(hits.values().sum::<u64>(), 8);
        // Everything, without a marker.
        let all = count(log.as_bytes(), None);
        assert_eq!(all.values().sum::<u64>(), 11);
    }

    #[test]
    fn phases_follow_the_inline_chain() {
        let f = |names: &[&str]| -> Vec<(String, String)> {
            names
                .iter()
                .map(|n| (n.to_string(), String::new()))
                .collect()
        };
        assert_eq!(
            phase(&f(&[
                "tetradrill_core::hierarchy::surface::bounding_sphere",
                "tetradrill_core::hierarchy::nearest::<impl>::nearest_walk"
            ])),
            "contact search"
        );
        assert_eq!(
            phase(&f(&[
                "tetradrill_core::hash::table::SpatialHash::query_box_once"
            ])),
            "candidate query"
        );
        assert_eq!(
            phase(&f(&["tetradrill_core::drill::step::Drill::process"])),
            "drill"
        );
        assert_eq!(
            phase(&f(&["fmaxf"])),
            "runtime (libm, compiler builtins, output)"
        );
    }
}
