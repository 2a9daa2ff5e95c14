//! The value of every `--drive FAMILY` option (`sim`, `dump`, `protocol
//! budget`, `protocol dbc`): one parser whose accepted names and `--help`
//! list both come from [`Family::ALL`], so a new family appears in every
//! command's help the day it is added (issue 46: `sim --help` and
//! `protocol dbc --help` had hand-written lists without `mit`).

use anguilla_protocol::Family;
use anguilla_protocol::family::UnknownFamily;
use clap::builder::{PossibleValue, TypedValueParser};

/// Parses a drive family's name ([`Family::ALL`]); `--help` lists every
/// family with its description. A name that is none of them is an error
/// listing them.
#[derive(Debug, Clone, Copy, Default)]
pub struct FamilyParser;

impl TypedValueParser for FamilyParser {
    type Value = Family;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &std::ffi::OsStr,
    ) -> Result<Family, clap::Error> {
        let text = value.to_string_lossy();
        text.parse().map_err(|e: UnknownFamily| {
            let arg = arg.map_or_else(|| "--drive".to_owned(), |a| a.to_string());
            clap::Error::raw(
                clap::error::ErrorKind::InvalidValue,
                format!("invalid value '{text}' for '{arg}': {e}\n"),
            )
            .with_cmd(cmd)
        })
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(Box::new(
            Family::ALL
                .into_iter()
                .map(|f| PossibleValue::new(f.name()).help(f.description())),
        ))
    }
}
