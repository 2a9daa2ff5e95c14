//! Decoded frames in words for `dump`: the protocols' messages are Rust
//! values; their `Debug` text (`Heartbeat(Heartbeat { node: NodeId(5),
//! state: BootUp })`) is read back as a tree and written flat, as
//! `heartbeat node=5 state=BootUp`: the message's name, then each field
//! (nested ones as `pitch.position=…`), newtype wrappers dropped.

/// One value of a `Debug` text.
#[derive(Debug, Clone, PartialEq)]
enum Value {
    /// A number, a string, a unit variant, `None`.
    Atom(String),
    /// `Name(a, b)` (a tuple struct or variant, `Some(x)`).
    Tuple(String, Vec<Value>),
    /// `Name { field: value, … }`.
    Struct(String, Vec<(String, Value)>),
    /// `[a, b]`.
    List(Vec<Value>),
}

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
}

impl Parser<'_> {
    fn ws(&mut self) {
        while self.i < self.s.len() && self.s[self.i] == b' ' {
            self.i += 1;
        }
    }

    fn eat(&mut self, c: u8) -> bool {
        self.ws();
        if self.s.get(self.i) == Some(&c) {
            self.i += 1;
            true
        } else {
            false
        }
    }

    fn token(&mut self) -> Option<String> {
        self.ws();
        let start = self.i;
        if self.s.get(self.i) == Some(&b'"') {
            self.i += 1;
            while self.i < self.s.len() && self.s[self.i] != b'"' {
                self.i += if self.s[self.i] == b'\\' { 2 } else { 1 };
            }
            self.i = (self.i + 1).min(self.s.len());
        } else {
            while self.i < self.s.len() && !b" ,(){}[]:".contains(&self.s[self.i]) {
                self.i += 1;
            }
        }
        (self.i > start).then(|| String::from_utf8_lossy(&self.s[start..self.i]).into_owned())
    }

    fn values(&mut self, close: u8) -> Option<Vec<Value>> {
        let mut v = Vec::new();
        if self.eat(close) {
            return Some(v);
        }
        loop {
            v.push(self.value()?);
            if self.eat(close) {
                return Some(v);
            }
            if !self.eat(b',') {
                return None;
            }
            // A trailing comma before the close.
            if self.eat(close) {
                return Some(v);
            }
        }
    }

    fn value(&mut self) -> Option<Value> {
        if self.eat(b'[') {
            return self.values(b']').map(Value::List);
        }
        let name = self.token()?;
        if self.eat(b'(') {
            return self.values(b')').map(|v| Value::Tuple(name, v));
        }
        if self.eat(b'{') {
            let mut fields = Vec::new();
            if self.eat(b'}') {
                return Some(Value::Struct(name, fields));
            }
            loop {
                let f = self.token()?;
                if !self.eat(b':') {
                    return None;
                }
                fields.push((f, self.value()?));
                if self.eat(b'}') {
                    return Some(Value::Struct(name, fields));
                }
                if !self.eat(b',') {
                    return None;
                }
            }
        }
        Some(Value::Atom(name))
    }
}

/// `CamelCase` as `camel case`, lower-case.
fn words(name: &str) -> String {
    let mut out = String::new();
    for (i, c) in name.chars().enumerate() {
        if c.is_ascii_uppercase() && i > 0 {
            out.push(' ');
        }
        out.push(c.to_ascii_lowercase());
    }
    out
}

/// A value as text: a newtype's content, a list's items.
fn text(v: &Value) -> String {
    match v {
        Value::Atom(a) => a.clone(),
        Value::Tuple(_, items) if items.len() == 1 => text(&items[0]),
        Value::Tuple(name, items) => format!(
            "{name}({})",
            items.iter().map(text).collect::<Vec<_>>().join(", ")
        ),
        Value::List(items) => format!(
            "[{}]",
            items.iter().map(text).collect::<Vec<_>>().join(", ")
        ),
        Value::Struct(_, fields) => {
            let mut out = Vec::new();
            fields_into(&mut out, "", fields);
            format!("{{{}}}", out.join(" "))
        }
    }
}

fn fields_into(out: &mut Vec<String>, prefix: &str, fields: &[(String, Value)]) {
    for (f, v) in fields {
        // A variant wrapping a struct (`SetInputPos(InputPos { … })`) is
        // named by the variant.
        let named = match v {
            Value::Tuple(name, items) if items.len() == 1 => match unwrap(&items[0]) {
                Value::Struct(_, inner) => Some((name, inner)),
                _ => None,
            },
            Value::Struct(name, inner) => Some((name, inner)),
            _ => None,
        };
        match named.ok_or(unwrap(v)) {
            Ok((name, inner)) => {
                // An enum's variant (`sdo: Download { … }`) says what the
                // fields are: kept; a type named as its field is not.
                if name.to_ascii_lowercase() != f.replace('_', "") {
                    out.push(format!("{prefix}{f}={name}"));
                }
                fields_into(out, &format!("{prefix}{f}."), inner)
            }
            Err(other) => out.push(format!("{prefix}{f}={}", text(other))),
        }
    }
}

/// Through newtype wrappers to what they hold.
fn unwrap(v: &Value) -> &Value {
    match v {
        Value::Tuple(_, items) if items.len() == 1 => unwrap(&items[0]),
        other => other,
    }
}

/// A decoded message's `Debug` text, flat: `heartbeat node=5
/// state=BootUp`. Text it cannot read is returned as it is.
pub fn plain(debug: &str) -> String {
    let mut p = Parser {
        s: debug.as_bytes(),
        i: 0,
    };
    let Some(v) = p.value().filter(|_| {
        p.ws();
        p.i == p.s.len()
    }) else {
        return debug.to_string();
    };
    let (name, rest) = match &v {
        Value::Atom(a) => return words(a),
        Value::Tuple(name, items) if items.len() == 1 => (name, unwrap(&items[0])),
        Value::Tuple(name, _) => (name, &v),
        Value::Struct(name, _) => (name, &v),
        Value::List(_) => return text(&v),
    };
    let mut out = vec![words(name)];
    match rest {
        Value::Struct(_, fields) => fields_into(&mut out, "", fields),
        Value::Tuple(_, items) => out.extend(items.iter().map(text)),
        other => out.push(text(other)),
    }
    out.join(" ")
}

#[cfg(test)]
mod tests {
    use super::plain;

    #[test]
    fn messages_read_flat() {
        assert_eq!(
            plain("Heartbeat(Heartbeat { node: NodeId(5), state: BootUp })"),
            "heartbeat node=5 state=BootUp"
        );
        assert_eq!(plain("Sync { counter: 7 }"), "sync counter=7");
        assert_eq!(plain("EStop(All)"), "e stop All");
        assert_eq!(
            plain(
                "Setpoint(Setpoint { node: NodeId(3), pitch: AxisSetpoint { position: 0.1, torque: -0.25 } })"
            ),
            "setpoint node=3 pitch=AxisSetpoint pitch.position=0.1 pitch.torque=-0.25"
        );
        assert_eq!(
            plain("Message { node: 1, body: SetInputPos(InputPos { input_pos: 1.0 }) }"),
            "message node=1 body=SetInputPos body.input_pos=1.0"
        );
        assert_eq!(
            plain("Sdo { node: 4, data: [1, 2, 3], note: \"a, b\" }"),
            "sdo node=4 data=[1, 2, 3] note=\"a, b\""
        );
        // What it cannot read stays as it was.
        assert_eq!(plain("Broken { node: "), "Broken { node: ");
    }
}
