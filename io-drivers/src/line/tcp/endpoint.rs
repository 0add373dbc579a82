//! Where a network bus connects: `tcp://HOST:PORT` (Modbus TCP) or `rtu+tcp://HOST:PORT` (RTU
//! frames through a serial device server), parsed once into a typed value.

use std::fmt;

/// How requests travel over the connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NetFraming {
    /// Modbus TCP (MBAP header, transaction ids): a TCP device or a TCP-to-RTU gateway that
    /// turns each request into an RTU frame for the unit id behind it.
    ModbusTcp,
    /// RTU frames as they are on the wire, passed through by a serial device server (a
    /// "transparent" or "raw TCP" mode): the serial line's timing and the RTU codec apply.
    RtuOverTcp,
}

impl NetFraming {
    /// The URL scheme.
    pub fn scheme(self) -> &'static str {
        match self {
            NetFraming::ModbusTcp => "tcp",
            NetFraming::RtuOverTcp => "rtu+tcp",
        }
    }
}

/// A validated network endpoint of a bus.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct TcpEndpoint {
    /// How requests are framed.
    pub framing: NetFraming,
    /// A host name or an IP address (an IPv6 address without its brackets).
    pub host: String,
    /// The TCP port (Modbus TCP's registered port is 502).
    pub port: u16,
}

/// Why a `port:` URL is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EndpointError {
    /// The scheme is neither `tcp` nor `rtu+tcp`.
    #[error("unknown scheme (expected tcp://HOST:PORT or rtu+tcp://HOST:PORT)")]
    UnknownScheme,
    /// Nothing between `://` and `:PORT`.
    #[error("no host (expected tcp://HOST:PORT)")]
    MissingHost,
    /// No `:PORT` after the host.
    #[error("no port (expected tcp://HOST:PORT; Modbus TCP's port is 502)")]
    MissingPort,
    /// The port is not a number in 1..=65535.
    #[error("port is not a number in 1..=65535")]
    BadPort,
    /// Something after the port (a path, a query), or a host with characters no host has.
    #[error("unexpected characters after HOST:PORT, or in the host")]
    Trailing,
}

impl TcpEndpoint {
    /// Parses `text` when it is a URL (it holds `://`): `Ok(None)` for anything else (a device
    /// path), `Err` for a URL that is not a valid endpoint.
    pub fn parse(text: &str) -> Result<Option<Self>, EndpointError> {
        let Some((scheme, rest)) = text.split_once("://") else {
            return Ok(None);
        };
        let framing = match scheme {
            "tcp" => NetFraming::ModbusTcp,
            "rtu+tcp" => NetFraming::RtuOverTcp,
            _ => return Err(EndpointError::UnknownScheme),
        };
        let rest = rest.strip_suffix('/').unwrap_or(rest);
        let (host, port) = if let Some(v6) = rest.strip_prefix('[') {
            let (host, after) = v6.split_once(']').ok_or(EndpointError::Trailing)?;
            match after.strip_prefix(':') {
                Some(port) => (host, port),
                None if after.is_empty() => return Err(EndpointError::MissingPort),
                None => return Err(EndpointError::Trailing),
            }
        } else {
            match rest.rsplit_once(':') {
                Some((host, port)) => (host, port),
                None if rest.contains('/') => return Err(EndpointError::Trailing),
                None => {
                    return Err(if rest.is_empty() {
                        EndpointError::MissingHost
                    } else {
                        EndpointError::MissingPort
                    })
                }
            }
        };
        if host.is_empty() {
            return Err(EndpointError::MissingHost);
        }
        if host
            .chars()
            .any(|c| !(c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_' | ':')))
        {
            return Err(EndpointError::Trailing);
        }
        if port.is_empty() {
            return Err(EndpointError::MissingPort);
        }
        if port.contains('/') || port.contains('?') {
            return Err(EndpointError::Trailing);
        }
        let port: u16 = port
            .parse()
            .ok()
            .filter(|p| *p > 0)
            .ok_or(EndpointError::BadPort)?;
        Ok(Some(Self {
            framing,
            host: host.to_string(),
            port,
        }))
    }

    /// `HOST:PORT`, as a socket address is looked up (IPv6 in brackets).
    pub fn authority(&self) -> String {
        if self.host.contains(':') {
            format!("[{}]:{}", self.host, self.port)
        } else {
            format!("{}:{}", self.host, self.port)
        }
    }
}

impl fmt::Display for TcpEndpoint {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}://{}", self.framing.scheme(), self.authority())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_both_schemes_and_refuses_bad_urls_by_reason() {
        let e = TcpEndpoint::parse("tcp://10.0.0.7:502").unwrap().unwrap();
        assert_eq!(
            (e.framing, e.host.as_str(), e.port),
            (NetFraming::ModbusTcp, "10.0.0.7", 502)
        );
        assert_eq!(e.to_string(), "tcp://10.0.0.7:502");
        let e = TcpEndpoint::parse("rtu+tcp://gw.local:4001")
            .unwrap()
            .unwrap();
        assert_eq!(e.framing, NetFraming::RtuOverTcp);
        assert_eq!(e.to_string(), "rtu+tcp://gw.local:4001");
        let e = TcpEndpoint::parse("tcp://[::1]:1502").unwrap().unwrap();
        assert_eq!(
            (e.host.as_str(), e.authority()),
            ("::1", "[::1]:1502".into())
        );
        assert_eq!(TcpEndpoint::parse("/dev/ttyUSB0"), Ok(None));
        assert_eq!(TcpEndpoint::parse("sim"), Ok(None));
        use EndpointError::*;
        for (url, err) in [
            ("udp://h:502", UnknownScheme),
            ("tcp://:502", MissingHost),
            ("tcp://", MissingHost),
            ("tcp://host", MissingPort),
            ("tcp://host:", MissingPort),
            ("tcp://[::1]", MissingPort),
            ("tcp://host:0", BadPort),
            ("tcp://host:65536", BadPort),
            ("tcp://host:50x", BadPort),
            ("tcp://host:502/path", Trailing),
            ("tcp://ho st:502", Trailing),
        ] {
            assert_eq!(TcpEndpoint::parse(url), Err(err), "{url}");
        }
    }
}
