//! The RESI-2RTD's sensor configuration as its ASCII commands write it: `GSCS`, `GSC1`,
//! `GSC2` answer and `SSCS`, `SSC1`, `SSC2` take `<Type>,<Current>,<Linearisation>,<Unit>`
//! (resi-catalog L6416–L6530), the names of the four nibbles of the channel's SENSOR_TYPE
//! register (4x06021 / 4x06041, L8707: TYPE bits 0..3, CURRENT 4..7, LINEARISATION 8..11,
//! UNIT 12..15). One word, two spellings: this file is where they meet.
//!
//! Where the two chapters differ, each keeps its own reading:
//! - current code 4 is "25µA" in the register's table (L8731) and `20MYA` in the ASCII list
//!   (L6441): the ASCII side says `20MYA` and takes `20MYA` (or `25MYA`) for code 4;
//! - the register gives code 15 the same meaning as 0 (the default, "15,0:PT100", L8718); written
//!   back by name it is 0;
//! - a nibble the register leaves undefined (a TYPE of 8..14, written over Modbus) is answered
//!   as its number, since the manual gives it no name; a name the lists do not have is refused
//!   (no answer, as for any malformed parameter: resi-spec §2.4).

/// The TYPE names, by code (L6426–L6434).
const TYPES: [&str; 8] = [
    "PT100",
    "PT1000",
    "PT1000_375",
    "PT10",
    "PT50",
    "PT200",
    "PT500",
    "NI120",
];
/// The CURRENT names, by code (L6437–L6445).
const CURRENTS: [&str; 8] = [
    "500MYA", "1MA", "5MYA", "10MYA", "20MYA", "50MYA", "100MYA", "250MYA",
];
/// The LINEARISATION names, by code (L6447–L6451).
const LINEARISATIONS: [&str; 5] = ["EUROPE", "AMERICA", "JAPAN", "ITS90", "DONT_CARE"];
/// The UNIT names, by code (L6454–L6456).
const UNITS: [&str; 3] = ["CELSIUS", "FAHRENHEIT", "KELVIN"];

/// The four nibbles' name lists, lowest first.
const NIBBLES: [&[&str]; 4] = [&TYPES, &CURRENTS, &LINEARISATIONS, &UNITS];

/// `<Type>,<Current>,<Linearisation>,<Unit>` of a SENSOR_TYPE word.
pub(crate) fn format(word: u16) -> String {
    let names: Vec<String> = NIBBLES
        .iter()
        .enumerate()
        .map(|(i, names)| {
            let code = (word >> (4 * i)) & 0xF;
            // 15 means the default, as 0 does (L8718).
            let code = if code == 15 { 0 } else { usize::from(code) };
            names
                .get(code)
                .map_or_else(|| code.to_string(), |n| (*n).to_string())
        })
        .collect();
    names.join(",")
}

/// The SENSOR_TYPE word of four names (`PT100,1MA,EUROPE,CELSIUS`), or `None` for anything
/// else.
pub(crate) fn parse(parts: &[&str]) -> Option<u16> {
    if parts.len() != NIBBLES.len() {
        return None;
    }
    parts
        .iter()
        .zip(NIBBLES)
        .enumerate()
        .try_fold(0u16, |word, (i, (part, names))| {
            let part = part.trim();
            // The register's spelling of code 4 is accepted too (see the module docs).
            let code = if i == 1 && part == "25MYA" {
                4
            } else {
                names.iter().position(|n| *n == part)?
            };
            Some(word | (u16::try_from(code).ok()? << (4 * i)))
        })
}

/// The answer of `GSCS`: `S1,<config 1>,S2,<config 2>` (L6420).
pub(crate) fn format_both(words: &[u16]) -> String {
    words
        .iter()
        .enumerate()
        .map(|(i, w)| format!("S{},{}", i + 1, format(*w)))
        .collect::<Vec<_>>()
        .join(",")
}

/// The parameters of `SSCS` (`S1,<config 1>,S2,<config 2>`, L6493) as two words.
pub(crate) fn parse_both(parts: &[&str]) -> Option<[u16; 2]> {
    let [s1, a, b, c, d, s2, e, f, g, h] = parts else {
        return None;
    };
    if s1.trim() != "S1" || s2.trim() != "S2" {
        return None;
    }
    Some([parse(&[a, b, c, d])?, parse(&[e, f, g, h])?])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_word_is_pt100_500ua_europe_celsius() {
        assert_eq!(format(0), "PT100,500MYA,EUROPE,CELSIUS");
        assert_eq!(
            format(0xFFFF),
            "PT100,500MYA,EUROPE,CELSIUS",
            "15 is the default"
        );
    }

    #[test]
    fn each_nibble_has_its_name() {
        // NI120 (7), 1 mA (1), ITS-90 (3), Kelvin (2).
        let word = 0x2317;
        assert_eq!(format(word), "NI120,1MA,ITS90,KELVIN");
        assert_eq!(parse(&["NI120", "1MA", "ITS90", "KELVIN"]), Some(word));
    }

    #[test]
    fn the_two_spellings_of_current_four() {
        assert_eq!(format(0x0040), "PT100,20MYA,EUROPE,CELSIUS");
        assert_eq!(
            parse(&["PT100", "25MYA", "EUROPE", "CELSIUS"]),
            Some(0x0040)
        );
        assert_eq!(
            parse(&["PT100", "20MYA", "EUROPE", "CELSIUS"]),
            Some(0x0040)
        );
    }

    #[test]
    fn an_undefined_code_is_answered_as_its_number_and_a_wrong_name_refused() {
        assert_eq!(format(0x0009), "9,500MYA,EUROPE,CELSIUS");
        assert_eq!(parse(&["PT99", "1MA", "EUROPE", "CELSIUS"]), None);
        assert_eq!(parse(&["PT100", "1MA", "EUROPE"]), None);
    }

    #[test]
    fn both_channels() {
        assert_eq!(
            format_both(&[0, 0x2317]),
            "S1,PT100,500MYA,EUROPE,CELSIUS,S2,NI120,1MA,ITS90,KELVIN"
        );
        let parts: Vec<&str> = "S1,PT100,500MYA,EUROPE,CELSIUS,S2,NI120,1MA,ITS90,KELVIN"
            .split(',')
            .collect();
        assert_eq!(parse_both(&parts), Some([0, 0x2317]));
        let swapped: Vec<&str> = "S2,PT100,500MYA,EUROPE,CELSIUS,S1,NI120,1MA,ITS90,KELVIN"
            .split(',')
            .collect();
        assert_eq!(parse_both(&swapped), None);
    }
}
