//! Checks of a JPEG's structure before it is decoded, for the two ways a damaged file would
//! otherwise become a drawing (the first step of [`super::ingest`]): a lenient decoder
//! fills whatever data are missing with grey, and the edge of the fill is a wall nobody
//! drew.
//!
//! - [`jpeg_is_complete`]: the file reaches its end-of-image marker (a cut file does not).
//! - [`jpeg_data_can_fill_header`]: its entropy-coded data are long enough for the picture
//!   its header declares (a header claiming 4000 × 4000 px over 540 × 390 px of data is
//!   not), by a lower bound on the bits each 8 × 8 block needs, read from the file's own
//!   Huffman tables.
//!
//! Both walk the marker segments once: O(bytes), no pixel decoded (ITU-T T.81, annex B).

/// One marker segment or entropy-coded scan of a JPEG, as the walk finds it.
enum Segment<'a> {
    /// A marker with its payload (after the 2-byte length).
    Marker(u8, &'a [u8]),
    /// The entropy-coded data after a start-of-scan, without stuffed zero bytes and
    /// restart markers: how many bytes.
    ScanData(usize),
    /// The end-of-image marker.
    End,
}

/// Walks the segments after the start-of-image (`FF D8`), calling `visit` on each, and
/// returns whether the walk reached `FF D9`. Each segment has a 2-byte length after its
/// marker; after a start-of-scan (`FF DA`) the entropy-coded data follow, in which a `FF`
/// byte is always stuffed (`FF 00`) or a restart marker (`FF D0`–`FF D7`); the next other
/// marker ends the scan (B.1.1, F.1.2.3).
fn walk<'a>(bytes: &'a [u8], mut visit: impl FnMut(Segment<'a>)) -> bool {
    let mut i = 2;
    while i + 1 < bytes.len() {
        if bytes[i] != 0xFF {
            return false;
        }
        let marker = bytes[i + 1];
        match marker {
            0xD9 => {
                visit(Segment::End);
                return true;
            }
            // Fill bytes before a marker.
            0xFF => i += 1,
            // Markers without a length.
            0x01 | 0xD0..=0xD7 => i += 2,
            _ => {
                let Some(len) = bytes.get(i + 2..i + 4) else {
                    return false;
                };
                let len = u16::from_be_bytes([len[0], len[1]]) as usize;
                let payload = bytes.get(i + 4..i + 2 + len.max(2)).unwrap_or(&[]);
                visit(Segment::Marker(marker, payload));
                i += 2 + len;
                if marker == 0xDA {
                    // Entropy-coded data up to the next marker that is not a stuffed byte
                    // or a restart.
                    let (mut data, mut skipped) = (i, 0);
                    while data + 1 < bytes.len() {
                        match (bytes[data], bytes[data + 1]) {
                            (0xFF, 0x00) => {
                                skipped += 1;
                                data += 2;
                            }
                            (0xFF, 0xD0..=0xD7) => {
                                skipped += 2;
                                data += 2;
                            }
                            (0xFF, _) => break,
                            _ => data += 1,
                        }
                    }
                    // A header running past the end leaves no data (`data` is then `i`).
                    let span = data.min(bytes.len()).saturating_sub(i);
                    visit(Segment::ScanData(span.saturating_sub(skipped)));
                    i = data;
                }
            }
        }
    }
    false
}

/// True when a JPEG reaches its end-of-image marker after its image data; a file cut
/// anywhere before it is incomplete.
pub fn jpeg_is_complete(bytes: &[u8]) -> bool {
    walk(bytes, |_| {})
}

/// A Huffman table's code lengths: `counts[l]` codes of `l + 1` bits, for the symbols in
/// order (B.2.4.2).
struct HuffmanLengths {
    counts: [u8; 16],
    symbols: Vec<u8>,
}

impl HuffmanLengths {
    /// The shortest code, bits.
    fn shortest_bits(&self) -> Option<u32> {
        self.counts
            .iter()
            .position(|&c| c > 0)
            .map(|l| l as u32 + 1)
    }

    /// The length of `symbol`'s code, bits (symbols are listed by increasing length).
    fn bits_of(&self, symbol: u8) -> Option<u32> {
        let k = self.symbols.iter().position(|&s| s == symbol)?;
        let mut seen = 0usize;
        for (l, &c) in self.counts.iter().enumerate() {
            seen += c as usize;
            if k < seen {
                return Some(l as u32 + 1);
            }
        }
        None
    }
}

/// One frame component: its id and sampling factors.
struct FrameComponent {
    id: u8,
    h: u32,
    v: u32,
}

/// Whether the entropy-coded data of a JPEG are long enough for the picture its header
/// declares.
///
/// Lower bound: every 8 × 8 block of every component is coded in the scan that carries its
/// DC coefficient, with at least the shortest code of that scan's DC table; in a
/// sequential scan that also holds all AC coefficients, at least the end-of-block code too
/// (or 63 of the shortest AC codes, when the block has no end-of-block); a progressive DC
/// refinement scan, one raw bit a block; an AC scan of a progressive file, nothing (one
/// end-of-band run may cover every block). A component of
/// `w_c × h_c` samples, `w_c = ⌈W h / H_max⌉`, has at least `⌈w_c/8⌉ ⌈h_c/8⌉` blocks
/// (A.1.1; an interleaved scan codes more, padding its MCUs). So the scan needs at least
///
/// ```text
/// Σ_components blocks_c · (dc_min + [Ss = 0, Se = 63] · min(eob_bits, 63 · ac_min)) bits
/// ```
///
/// A white page costs about this (a 2-bit DC difference of 0 and a 4-bit end-of-block per
/// block in the standard tables); a 4000 × 4000 header over 540 × 390 data needs 187 kB
/// and has about 30. The bound is never above what a valid file holds, so no whole file is
/// refused; a file cut short and closed by hand passes unless it falls below it. `true`
/// when the file is not one the bound covers (no frame, arithmetic coding, a table
/// missing). O(bytes).
pub fn jpeg_data_can_fill_header(bytes: &[u8]) -> bool {
    let mut frame: Option<(u32, u32, Vec<FrameComponent>)> = None;
    let mut tables: [[Option<HuffmanLengths>; 4]; 2] = Default::default();
    let mut short = false;
    let mut unknown = false;
    let mut pending_need_bits: Option<u64> = None;
    walk(bytes, |segment| match segment {
        // Baseline, extended, progressive Huffman frames.
        Segment::Marker(0xC0..=0xC2, p) if p.len() >= 6 => {
            let height = u16::from_be_bytes([p[1], p[2]]) as u32;
            let width = u16::from_be_bytes([p[3], p[4]]) as u32;
            let n = p[5] as usize;
            let components = (0..n)
                .filter_map(|k| {
                    let c = p.get(6 + 3 * k..9 + 3 * k)?;
                    Some(FrameComponent {
                        id: c[0],
                        h: (c[1] >> 4).max(1) as u32,
                        v: (c[1] & 15).max(1) as u32,
                    })
                })
                .collect();
            frame = Some((width, height, components));
        }
        // Other frames (lossless, arithmetic, hierarchical): not covered.
        Segment::Marker(0xC3 | 0xC5..=0xC7 | 0xC9..=0xCB | 0xCD..=0xCF, _) => unknown = true,
        Segment::Marker(0xC4, mut p) => {
            while p.len() >= 17 {
                let (class, id) = ((p[0] >> 4) as usize, (p[0] & 15) as usize);
                let mut counts = [0u8; 16];
                counts.copy_from_slice(&p[1..17]);
                let n: usize = counts.iter().map(|&c| c as usize).sum();
                let Some(symbols) = p.get(17..17 + n) else {
                    break;
                };
                if class < 2 && id < 4 {
                    tables[class][id] = Some(HuffmanLengths {
                        counts,
                        symbols: symbols.to_vec(),
                    });
                }
                p = &p[17 + n..];
            }
        }
        Segment::Marker(0xDA, p) => {
            pending_need_bits = scan_needs_bits(p, frame.as_ref(), &tables);
            if pending_need_bits.is_none() {
                unknown = true;
            }
        }
        Segment::ScanData(len) => {
            if let Some(need) = pending_need_bits.take() {
                short |= need > len as u64 * 8;
            }
        }
        _ => {}
    });
    unknown || !short
}

/// The least bits the scan whose header is `p` can take (see
/// [`jpeg_data_can_fill_header`]); `None` when its frame or a table is missing.
fn scan_needs_bits(
    p: &[u8],
    frame: Option<&(u32, u32, Vec<FrameComponent>)>,
    tables: &[[Option<HuffmanLengths>; 4]; 2],
) -> Option<u64> {
    let (width, height, components) = frame?;
    let h_max = components.iter().map(|c| c.h).max()?;
    let v_max = components.iter().map(|c| c.v).max()?;
    let n = *p.first()? as usize;
    let spectral = p.get(1 + 2 * n..4 + 2 * n)?;
    let (ss, se, ah) = (spectral[0], spectral[1], spectral[2] >> 4);
    let mut bits = 0u64;
    for k in 0..n {
        let c = p.get(1 + 2 * k..3 + 2 * k)?;
        let component = components.iter().find(|f| f.id == c[0])?;
        let samples_w = (*width * component.h).div_ceil(h_max);
        let samples_h = (*height * component.v).div_ceil(v_max);
        let blocks = u64::from(samples_w.div_ceil(8)) * u64::from(samples_h.div_ceil(8));
        let mut per_block = 0u64;
        if ss == 0 && ah > 0 {
            // A progressive DC refinement: one raw bit a block, no Huffman code (G.1.2.1).
            per_block = 1;
        } else if ss == 0 {
            let dc = tables[0][(c[1] >> 4) as usize & 3].as_ref()?;
            per_block += u64::from(dc.shortest_bits()?);
            if se == 63 {
                let ac = tables[1][(c[1] & 15) as usize & 3].as_ref()?;
                let all_coded = 63 * u64::from(ac.shortest_bits()?);
                per_block += ac
                    .bits_of(0x00)
                    .map_or(all_coded, |eob| u64::from(eob).min(all_coded));
            }
        }
        bits += blocks * per_block;
    }
    Some(bits)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use image::DynamicImage;
    use std::io::Cursor;

    /// A 540 × 390 drawing as a baseline JPEG (the sizes of the file that found the
    /// problem), grey or colour (4:2:0, interleaved).
    pub(crate) fn drawing_jpeg(colour: bool) -> Vec<u8> {
        let img = image::RgbImage::from_fn(540, 390, |x, y| {
            let wall = x < 6 || y < 6 || x >= 534 || y >= 384 || x == 270 || y == 200;
            image::Rgb(if wall { [20, 30, 90] } else { [250, 245, 235] })
        });
        let img = if colour {
            DynamicImage::ImageRgb8(img)
        } else {
            DynamicImage::ImageLuma8(DynamicImage::ImageRgb8(img).to_luma8())
        };
        let mut bytes = Vec::new();
        img.write_to(&mut Cursor::new(&mut bytes), image::ImageFormat::Jpeg)
            .unwrap();
        bytes
    }

    /// The offset of the start-of-frame's height field (`FF C0`, length, precision, height).
    pub(crate) fn sof_size_at(bytes: &[u8]) -> usize {
        bytes.windows(2).position(|w| w == [0xFF, 0xC0]).unwrap() + 5
    }

    #[test]
    fn standard_table_lengths_are_read_by_hand() {
        // The standard luminance DC table (K.3): 0 codes of 1 bit, 1 of 2 bits, 5 of 3,
        // 1 each of 4..9 bits; symbol 0 (category 0) has the 2-bit code 00.
        let dc = HuffmanLengths {
            counts: [0, 1, 5, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0],
            symbols: (0..12).collect(),
        };
        assert_eq!(dc.shortest_bits(), Some(2));
        assert_eq!(dc.bits_of(0), Some(2));
        assert_eq!(dc.bits_of(6), Some(4));
        assert_eq!(dc.bits_of(11), Some(9));
        assert_eq!(dc.bits_of(12), None);
        // The standard luminance AC table starts 0/2/1/3: 0x01, 0x02 (2 bits), 0x03 (3),
        // then 0x00 (EOB), 0x04, 0x11 (4 bits).
        let ac = HuffmanLengths {
            counts: [0, 2, 1, 3, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
            symbols: vec![0x01, 0x02, 0x03, 0x00, 0x04, 0x11],
        };
        assert_eq!(ac.bits_of(0x00), Some(4));
    }

    #[test]
    fn whole_files_pass_and_lying_headers_do_not() {
        for colour in [false, true] {
            let bytes = drawing_jpeg(colour);
            assert!(jpeg_is_complete(&bytes));
            assert!(jpeg_data_can_fill_header(&bytes), "colour {colour}");
            // 4000 × 4000 over the same data: 250 000 blocks need ≥ 187 kB (grey).
            let mut lying = bytes.clone();
            let at = sof_size_at(&lying);
            lying[at..at + 4].copy_from_slice(&[0x0F, 0xA0, 0x0F, 0xA0]);
            assert!(jpeg_is_complete(&lying));
            assert!(!jpeg_data_can_fill_header(&lying), "colour {colour}");
            // A header smaller than its data is not this check's business.
            let mut smaller = bytes.clone();
            smaller[at..at + 2].copy_from_slice(&200u16.to_be_bytes());
            assert!(jpeg_data_can_fill_header(&smaller));
        }
    }

    #[test]
    fn every_prefix_and_damaged_copy_is_walked_without_a_panic() {
        // Cut at every length, and each byte in turn set to FF (a marker where data were)
        // or 00: the checks answer, they never index out of the file or underflow.
        let bytes = drawing_jpeg(true);
        for keep in 0..bytes.len() {
            let _ = jpeg_is_complete(&bytes[..keep]);
            let _ = jpeg_data_can_fill_header(&bytes[..keep]);
        }
        for at in (0..bytes.len()).step_by(7) {
            for value in [0xFF, 0x00] {
                let mut damaged = bytes.clone();
                damaged[at] = value;
                let _ = jpeg_is_complete(&damaged);
                let _ = jpeg_data_can_fill_header(&damaged);
            }
        }
    }

    #[test]
    fn a_white_page_is_near_the_bound_and_passes() {
        // The tightest honest file: every block a DC difference of 0 and an end-of-block.
        let img = image::GrayImage::from_pixel(800, 600, image::Luma([255]));
        let mut bytes = Vec::new();
        DynamicImage::ImageLuma8(img)
            .write_to(&mut Cursor::new(&mut bytes), image::ImageFormat::Jpeg)
            .unwrap();
        assert!(jpeg_data_can_fill_header(&bytes));
        // Twice its height is more than its data can hold.
        let at = sof_size_at(&bytes);
        bytes[at..at + 2].copy_from_slice(&1200u16.to_be_bytes());
        assert!(!jpeg_data_can_fill_header(&bytes));
    }
}
