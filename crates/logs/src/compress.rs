//! Chunk compression, both ways: bz2 and lz4 for ROS 1 bags (ROS wiki Bags/Format/2.0: lz4
//! chunks are LZ4 *frames*, written by roslz4), zstd and lz4 frames for MCAP (MCAP spec,
//! "Chunk"). Pure-Rust codecs; a damaged stream is an error, never a panic.

use std::io::{Read, Write};

/// A chunk's compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Codec {
    None,
    Bz2,
    Lz4,
    Zstd,
}

impl Codec {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Codec::None => "uncompressed",
            Codec::Bz2 => "bz2",
            Codec::Lz4 => "lz4",
            Codec::Zstd => "zstd",
        }
    }
}

/// Capacity reserved up front: a damaged size field must not reserve gigabytes.
const MAX_RESERVE: u64 = 64 << 20;

/// Inflates `data`, which should give exactly `size` bytes. Returns what came out, and why the
/// stream is damaged if it is (then the bytes are what could be read before the damage).
pub(crate) fn decompress(codec: Codec, data: &[u8], size: u64) -> (Vec<u8>, Option<String>) {
    let mut out = Vec::with_capacity(size.min(MAX_RESERVE) as usize);
    let limit = size.saturating_add(1);
    let res = match codec {
        Codec::None => {
            out.extend_from_slice(&data[..data.len().min(limit as usize)]);
            Ok(0)
        }
        Codec::Bz2 => bzip2::read::BzDecoder::new(data)
            .take(limit)
            .read_to_end(&mut out),
        Codec::Lz4 => lz4_flex::frame::FrameDecoder::new(data)
            .take(limit)
            .read_to_end(&mut out),
        Codec::Zstd => unzstd(data, limit, &mut out),
    };
    let name = codec.name();
    let why = match res {
        Err(e) => Some(format!("the {name} data is damaged ({e})")),
        Ok(_) if out.len() as u64 > size => {
            out.truncate(size as usize);
            Some(format!(
                "the {name} data inflates to more than the {size} bytes its header says"
            ))
        }
        Ok(_) if (out.len() as u64) < size => Some(format!(
            "the {name} data ends after {} of the {size} bytes its header says",
            out.len()
        )),
        Ok(_) => None,
    };
    (out, why)
}

/// Inflates one zstd frame, checking its content checksum when it has one (RFC 8878 §3.1.1:
/// the low 32 bits of the XXH64 of the content), which the decoder computes but leaves to us.
fn unzstd(data: &[u8], limit: u64, out: &mut Vec<u8>) -> std::io::Result<usize> {
    let mut d = ruzstd::decoding::StreamingDecoder::new(data)
        .map_err(|e| std::io::Error::other(e.to_string()))?;
    let n = (&mut d).take(limit).read_to_end(out)?;
    let frame = d.into_frame_decoder();
    if frame.is_finished()
        && let (Some(want), Some(got)) = (
            frame.get_checksum_from_data(),
            frame.get_calculated_checksum(),
        )
        && want != got
    {
        return Err(std::io::Error::other("its checksum does not match"));
    }
    Ok(n)
}

/// Compresses `data` (in memory: chunks are a megabyte or so).
pub(crate) fn compress(codec: Codec, data: &[u8]) -> std::io::Result<Vec<u8>> {
    match codec {
        Codec::None => Ok(data.to_vec()),
        Codec::Bz2 => {
            // rosbag compresses with bzip2's block size 9.
            let mut e = bzip2::write::BzEncoder::new(Vec::new(), bzip2::Compression::best());
            e.write_all(data)?;
            e.finish()
        }
        Codec::Lz4 => {
            // A content checksum, as roslz4 writes, so that damage is caught on reading; 64 KiB
            // blocks, so that a chunk cut short still gives its first blocks.
            let info = lz4_flex::frame::FrameInfo::new()
                .content_checksum(true)
                .block_size(lz4_flex::frame::BlockSize::Max64KB);
            let mut e = lz4_flex::frame::FrameEncoder::with_frame_info(info, Vec::new());
            e.write_all(data)?;
            e.finish().map_err(std::io::Error::other)
        }
        Codec::Zstd => Ok(ruzstd::encoding::compress_to_vec(
            data,
            ruzstd::encoding::CompressionLevel::Fastest,
        )),
    }
}

/// Inflates a whole zstd frame of unknown size, up to `max` bytes (a message rosbag2
/// compressed on its own).
pub(crate) fn unzstd_whole(data: &[u8], max: u64) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    unzstd(data, max + 1, &mut out).map_err(|e| format!("the zstd data is damaged ({e})"))?;
    if out.len() as u64 > max {
        return Err(format!("the zstd data inflates to more than {max} bytes"));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_codec_round_trips_and_reports_damage() {
        let data: Vec<u8> = (0..100_000u32)
            .flat_map(|i| (i % 251).to_le_bytes())
            .collect();
        for codec in [Codec::None, Codec::Bz2, Codec::Lz4, Codec::Zstd] {
            let z = compress(codec, &data).unwrap();
            let (out, why) = decompress(codec, &z, data.len() as u64);
            assert_eq!(why, None, "{codec:?}");
            assert_eq!(out, data);
            let (_, why) = decompress(codec, &z, data.len() as u64 + 5);
            assert!(why.unwrap().contains("ends after"), "{codec:?}");
            let (out, why) = decompress(codec, &z, 10);
            assert!(why.unwrap().contains("more than"), "{codec:?}");
            assert_eq!(out.len(), 10);
            if codec != Codec::None {
                let (_, why) = decompress(codec, &z[..z.len() / 2], data.len() as u64);
                assert!(why.is_some(), "{codec:?}");
                let mut bad = z.clone();
                for i in (20..bad.len()).step_by(97) {
                    bad[i] ^= 0x5a;
                }
                let (_, why) = decompress(codec, &bad, data.len() as u64);
                assert!(why.is_some(), "{codec:?}");
            }
        }
    }
}
