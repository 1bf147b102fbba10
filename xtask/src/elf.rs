//! Section sizes of a 32-bit little-endian ELF file (the firmware images), summed the way
//! Berkeley `size` does: `text` = allocated read-only sections (code, constants, vector
//! table), `data` = allocated writable sections with contents (their initial values also
//! take flash), `bss` = allocated sections without contents (zeroed RAM).

use std::path::Path;

const SHF_WRITE: u32 = 1;
const SHF_ALLOC: u32 = 2;
const SHT_NOBITS: u32 = 8;

/// Bytes of text, data and bss.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sizes {
    pub text: u64,
    pub data: u64,
    pub bss: u64,
}

fn u16_at(bytes: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(bytes.get(at..at + 2)?.try_into().ok()?))
}

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?))
}

/// The sizes of an ELF32 little-endian image.
pub fn sizes(bytes: &[u8]) -> Result<Sizes, String> {
    if bytes.get(..6) != Some(&[0x7f, b'E', b'L', b'F', 1, 1][..]) {
        return Err("not a 32-bit little-endian ELF file".to_string());
    }
    let truncated = || "truncated ELF section table".to_string();
    let table = u32_at(bytes, 0x20).ok_or_else(truncated)? as usize;
    let entry = u16_at(bytes, 0x2e).ok_or_else(truncated)? as usize;
    let count = u16_at(bytes, 0x30).ok_or_else(truncated)? as usize;
    let mut sizes = Sizes::default();
    for i in 0..count {
        let at = table + i * entry;
        let kind = u32_at(bytes, at + 4).ok_or_else(truncated)?;
        let flags = u32_at(bytes, at + 8).ok_or_else(truncated)?;
        let size = u64::from(u32_at(bytes, at + 20).ok_or_else(truncated)?);
        if flags & SHF_ALLOC == 0 {
            continue;
        }
        if kind == SHT_NOBITS {
            sizes.bss += size;
        } else if flags & SHF_WRITE != 0 {
            sizes.data += size;
        } else {
            sizes.text += size;
        }
    }
    Ok(sizes)
}

/// Prints a size table of the firmware images `(label, path)`; fails if one is missing
/// or unreadable.
pub fn report(images: &[(String, std::path::PathBuf)], root: &Path) -> Result<(), String> {
    println!("| image | text | data | bss |");
    println!("|---|---|---|---|");
    for (label, path) in images {
        let full = root.join(path);
        let bytes =
            std::fs::read(&full).map_err(|e| format!("cannot read {}: {e}", full.display()))?;
        let s = sizes(&bytes).map_err(|e| format!("{}: {e}", full.display()))?;
        println!("| {label} | {} | {} | {} |", s.text, s.data, s.bss);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An ELF32 header and a section table of (type, flags, size) entries.
    fn image(sections: &[(u32, u32, u32)]) -> Vec<u8> {
        let mut bytes = vec![0u8; 52];
        bytes[..6].copy_from_slice(&[0x7f, b'E', b'L', b'F', 1, 1]);
        bytes[0x20..0x24].copy_from_slice(&52u32.to_le_bytes());
        bytes[0x2e..0x30].copy_from_slice(&40u16.to_le_bytes());
        bytes[0x30..0x32].copy_from_slice(&(sections.len() as u16).to_le_bytes());
        for &(kind, flags, size) in sections {
            let mut header = [0u8; 40];
            header[4..8].copy_from_slice(&kind.to_le_bytes());
            header[8..12].copy_from_slice(&flags.to_le_bytes());
            header[20..24].copy_from_slice(&size.to_le_bytes());
            bytes.extend_from_slice(&header);
        }
        bytes
    }

    #[test]
    fn sections_are_summed_like_berkeley_size() {
        let progbits = 1;
        let bytes = image(&[
            (0, 0, 0),                               // null
            (progbits, SHF_ALLOC, 8),                // vector table
            (progbits, SHF_ALLOC | 4, 1000),         // .text
            (progbits, SHF_ALLOC, 200),              // .rodata
            (progbits, SHF_ALLOC | SHF_WRITE, 16),   // .data
            (SHT_NOBITS, SHF_ALLOC | SHF_WRITE, 64), // .bss
            (progbits, 0, 500),                      // .comment: not loaded
        ]);
        assert_eq!(
            sizes(&bytes),
            Ok(Sizes {
                text: 1208,
                data: 16,
                bss: 64
            })
        );
        assert!(sizes(&bytes[..40]).is_err());
        assert!(sizes(b"\x7fELF\x02\x01").is_err());
    }
}
