//! Every reader is fuzzed like the CSV importers: a written bag and MCAP file, cut at many
//! offsets and with bytes changed in many places (deterministic pseudo-random), must give
//! messages or a located error: no panic, no hang, the path in every error.

use crate::common::*;
use hydrofit_logs::write::{BagCompression, McapCompression};
use hydrofit_logs::{LogError, Topic, mcap, ros1};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;
use std::time::{Duration, Instant};

/// xorshift64*: the same cases on every run.
pub(crate) struct Rng(pub(crate) u64);

impl Rng {
    pub(crate) fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    pub(crate) fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// The damaged copies of `good`: cuts, single flipped bytes, runs of 0x00/0xff (length
/// fields), and the tail (index, summary) damaged.
fn mutations(good: &[u8], seed: u64) -> Vec<(String, Vec<u8>)> {
    let mut rng = Rng(seed);
    let n = good.len();
    let mut out = Vec::new();
    for k in 0..120 {
        let cut = if k < 100 {
            k * n / 100
        } else {
            n - 1 - rng.below(64)
        };
        out.push((format!("cut at {cut}"), good[..cut].to_vec()));
    }
    // HYDROFIT_FUZZ_FLIPS=20000 for a longer hunt.
    let flips = std::env::var("HYDROFIT_FUZZ_FLIPS")
        .ok()
        .and_then(|v| v.parse().ok());
    for _ in 0..flips.unwrap_or(300) {
        let at = rng.below(n);
        let mask = 1 + rng.below(255) as u8;
        let mut bad = good.to_vec();
        bad[at] ^= mask;
        out.push((format!("byte {at} ^= {mask:#x}"), bad));
    }
    for k in 0..80 {
        let at = if k < 40 {
            rng.below(n)
        } else {
            n - 1 - rng.below(n.min(4096))
        };
        let fill = if k % 2 == 0 { 0xff } else { 0x00 };
        let mut bad = good.to_vec();
        let end = (at + 4).min(n);
        bad[at..end].fill(fill);
        out.push((format!("bytes {at}..{end} = {fill:#x}"), bad));
    }
    out
}

type Open<T> = fn(&Path, Vec<u8>) -> Result<(T, Vec<Topic>), LogError>;
type Read<T> = fn(
    &T,
    &Path,
    &[Topic],
    &[usize],
    &mut dyn FnMut(&hydrofit_logs::Message) -> Result<(), LogError>,
) -> Result<(), LogError>;

/// Opens and reads every topic of `data`; returns the messages read and the error, if any.
fn open_and_read<T>(
    path: &Path,
    data: Vec<u8>,
    open: Open<T>,
    read: Read<T>,
) -> (usize, Option<LogError>) {
    let (file, topics) = match open(path, data) {
        Ok(x) => x,
        Err(e) => return (0, Some(e)),
    };
    let all: Vec<usize> = (0..topics.len()).collect();
    let mut n = 0;
    let r = read(&file, path, &topics, &all, &mut |m| {
        assert!(m.topic < topics.len());
        n += 1;
        Ok(())
    });
    (n, r.err())
}

fn fuzz<T>(name: &str, good: &[u8], open: Open<T>, read: Read<T>) {
    let path = Path::new("fuzzed").join(name);
    let (total, e) = open_and_read(&path, good.to_vec(), open, read);
    assert!(
        e.is_none() && total > 100,
        "{name}: the undamaged file reads"
    );
    let (mut errors, mut cut_short) = (0, 0);
    for (case, data) in mutations(good, name.len() as u64 * 7919 + 1) {
        let len = data.len() as u64;
        let start = Instant::now();
        let r = catch_unwind(AssertUnwindSafe(|| open_and_read(&path, data, open, read)));
        let Ok((n, e)) = r else {
            panic!("{name}, {case}: the reader panicked");
        };
        assert!(
            start.elapsed() < Duration::from_secs(5),
            "{name}, {case}: too slow"
        );
        if let Some(e) = e {
            errors += 1;
            assert_eq!(e.path, path, "{name}, {case}");
            let at = e
                .offset
                .unwrap_or_else(|| panic!("{name}, {case}: no offset in {e}"));
            assert!(at <= len, "{name}, {case}: offset {at} past the end");
        } else if n < total {
            // Cuts, and messages whose opcode was changed (MCAP readers skip unknown opcodes).
            cut_short += 1;
        }
    }
    eprintln!("{name}: {errors} located errors, {cut_short} read in part");
}

#[test]
fn fuzzed_bags_never_panic() {
    for c in [
        BagCompression::None,
        BagCompression::Bz2,
        BagCompression::Lz4,
    ] {
        let path = tmp(&format!("fuzz-{c:?}.bag"));
        write_bag(&path, c, 2.0, Some(16 * 1024));
        let good = std::fs::read(&path).unwrap();
        fuzz(
            &format!("{c:?}.bag"),
            &good,
            ros1::Bag::open,
            ros1::Bag::read,
        );
    }
}

#[test]
fn fuzzed_mcap_files_never_panic() {
    for c in [
        McapCompression::Unchunked,
        McapCompression::None,
        McapCompression::Zstd,
        McapCompression::Lz4,
    ] {
        let path = tmp(&format!("fuzz-{c:?}.mcap"));
        write_mcap(&path, c, 2.0, Some(16 * 1024));
        let good = std::fs::read(&path).unwrap();
        fuzz(
            &format!("{c:?}.mcap"),
            &good,
            mcap::File::open,
            mcap::File::read,
        );
    }
}

/// Compressed data damaged in the middle of the file: always an error, never wrong numbers.
#[test]
fn corrupt_compressed_chunks_are_errors() {
    let mut rng = Rng(42);
    let bag = |c| {
        let path = tmp(&format!("zfuzz-{c:?}.bag"));
        write_bag(&path, c, 2.0, Some(16 * 1024));
        std::fs::read(&path).unwrap()
    };
    let mc = |c| {
        let path = tmp(&format!("zfuzz-{c:?}.mcap"));
        write_mcap(&path, c, 2.0, Some(16 * 1024));
        std::fs::read(&path).unwrap()
    };
    let files: Vec<(&str, Vec<u8>, bool)> = vec![
        ("bz2.bag", bag(BagCompression::Bz2), true),
        ("lz4.bag", bag(BagCompression::Lz4), true),
        ("zstd.mcap", mc(McapCompression::Zstd), false),
        ("lz4.mcap", mc(McapCompression::Lz4), false),
    ];
    for (name, good, is_bag) in files {
        let chunks = chunk_data(&good, is_bag);
        assert!(chunks.len() > 3, "{name}");
        for k in 0..40 {
            let (start, end) = chunks[k % chunks.len()];
            let at = start + rng.below(end - start - 3);
            let mut bad = good.clone();
            bad[at..at + 3]
                .iter_mut()
                .for_each(|b| *b = b.wrapping_add(0x37));
            let path = Path::new(name);
            let (_, e) = if is_bag {
                open_and_read(path, bad, ros1::Bag::open, ros1::Bag::read)
            } else {
                open_and_read(path, bad, mcap::File::open, mcap::File::read)
            };
            let e = e.unwrap_or_else(|| panic!("{name}: damage at {at} not seen"));
            assert!(e.offset.is_some(), "{name}: {e}");
        }
    }
}

/// Where the compressed data of each chunk is: ROS 1 records are `u32` header length, header,
/// `u32` data length, data (a chunk has `op=0x05` in its header); MCAP records are opcode,
/// `u64` length, body (a chunk body has 3 `u64`, a `u32` CRC, the compression string and the
/// records' `u64` length before them).
fn chunk_data(file: &[u8], is_bag: bool) -> Vec<(usize, usize)> {
    let u32_at = |p: usize| u32::from_le_bytes(file[p..p + 4].try_into().unwrap()) as usize;
    let u64_at = |p: usize| u64::from_le_bytes(file[p..p + 8].try_into().unwrap()) as usize;
    let mut out = Vec::new();
    if is_bag {
        let mut pos = 13;
        while pos + 8 <= file.len() {
            let hlen = u32_at(pos);
            let header = &file[pos + 4..pos + 4 + hlen];
            let dlen = u32_at(pos + 4 + hlen);
            let data = pos + 8 + hlen;
            if header.windows(4).any(|w| w == b"op=\x05") {
                out.push((data, data + dlen));
            }
            pos = data + dlen;
        }
    } else {
        let mut pos = 8;
        while pos + 9 <= file.len() - 8 {
            let (op, len) = (file[pos], u64_at(pos + 1));
            if op == 0x06 {
                let name = u32_at(pos + 9 + 28);
                let records = pos + 9 + 32 + name + 8;
                out.push((records, pos + 9 + len));
            }
            pos += 9 + len;
        }
    }
    out
}
