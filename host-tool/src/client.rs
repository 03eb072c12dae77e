//! The host's side of the link ([`Client`]): requests numbered and sent as frames, answers
//! matched by number, events kept in arrival order; a serial port (`--port`) or a TCP
//! socket (`--tcp`, the emulator's or a simulated device's) as transport ([`connect`]).
//! Every failure is a [`ToolError`] with its own exit code.

use pmsm_link::frame::{self, FrameReader, Pushed, MAX_FRAME};
use pmsm_link::{DeviceMsg, Event, HostMsg, LinkError, Request, Response, PROTOCOL_VERSION};
use std::collections::VecDeque;
use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

/// Why the tool failed; [`ToolError::exit_code`] is its process exit code.
#[derive(Debug)]
pub enum ToolError {
    /// The port or socket could not be opened.
    Port(String),
    /// The device speaks another protocol version.
    Version {
        /// The device's.
        device: u16,
        /// This tool's.
        host: u16,
    },
    /// The device did not answer in time.
    Timeout(String),
    /// The device refused the request.
    Device(LinkError),
    /// The link broke (closed, read or write failed).
    Io(std::io::Error),
    /// Anything else (a bad argument, a file).
    Other(anyhow::Error),
}

impl ToolError {
    /// 3 port, 4 version, 5 timeout, 6 refused by the device, 7 link broken, 1 other (clap's
    /// usage errors are 2).
    pub fn exit_code(&self) -> i32 {
        match self {
            Self::Port(_) => 3,
            Self::Version { .. } => 4,
            Self::Timeout(_) => 5,
            Self::Device(_) => 6,
            Self::Io(_) => 7,
            Self::Other(_) => 1,
        }
    }
}

impl std::fmt::Display for ToolError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Port(e) => write!(f, "cannot open the link: {e}"),
            Self::Version { device, host } => write!(
                f,
                "protocol version mismatch: the device speaks version {device}, this tool {host}: update the firmware or the tool"
            ),
            Self::Timeout(what) => write!(f, "the device did not answer ({what}): is it powered, on this port, running the link firmware?"),
            Self::Device(e) => write!(f, "the device refused: {e}"),
            Self::Io(e) => write!(f, "link error: {e}"),
            Self::Other(e) => write!(f, "{e:#}"),
        }
    }
}

impl std::error::Error for ToolError {}

impl From<anyhow::Error> for ToolError {
    fn from(e: anyhow::Error) -> Self {
        Self::Other(e)
    }
}

impl From<LinkError> for ToolError {
    fn from(e: LinkError) -> Self {
        match e {
            LinkError::VersionMismatch { device, host } => Self::Version { device, host },
            e => Self::Device(e),
        }
    }
}

/// A byte stream the client speaks over: reads return within a short timeout.
pub trait Transport: Read + Write + Send {}
impl<T: Read + Write + Send> Transport for T {}

/// How long a read waits before the client looks at its deadline.
const POLL: Duration = Duration::from_millis(20);

/// Where the device is.
#[derive(Clone, Debug)]
pub enum Target {
    /// A serial port and its baud rate.
    Serial(String, u32),
    /// A TCP address (`host:port`).
    Tcp(String),
}

/// Opens the transport to `target` and says hello: the device's answer checked for the
/// protocol version, within `timeout`.
pub fn connect(
    target: &Target,
    timeout: Duration,
) -> Result<Client<Box<dyn Transport>>, ToolError> {
    let io: Box<dyn Transport> = match target {
        Target::Serial(port, baud) => Box::new(
            serialport::new(port, *baud)
                .timeout(POLL)
                .open()
                .map_err(|e| ToolError::Port(format!("{port}: {e}")))?,
        ),
        Target::Tcp(addr) => {
            let s =
                TcpStream::connect(addr).map_err(|e| ToolError::Port(format!("{addr}: {e}")))?;
            s.set_read_timeout(Some(POLL)).map_err(ToolError::Io)?;
            s.set_nodelay(true).map_err(ToolError::Io)?;
            Box::new(s)
        }
    };
    let mut c = Client::new(io, timeout);
    c.hello()?;
    Ok(c)
}

/// The host's side of the link (module doc).
pub struct Client<T: Read + Write> {
    io: T,
    rx: FrameReader,
    /// Bytes read and not yet taken: `buf[pos..len]`.
    buf: [u8; 256],
    pos: usize,
    len: usize,
    seq: u16,
    /// How long a request waits for its answer.
    pub timeout: Duration,
    /// Events received, oldest first, not yet taken.
    events: VecDeque<Event>,
    /// Whether the device holds a valid configuration (from the hello).
    pub configured: bool,
}

impl<T: Read + Write> Client<T> {
    /// A client on `io` (whose reads time out), nothing sent yet.
    pub fn new(io: T, timeout: Duration) -> Self {
        Self {
            io,
            rx: FrameReader::new(),
            buf: [0; 256],
            pos: 0,
            len: 0,
            seq: 0,
            timeout,
            events: VecDeque::new(),
            configured: false,
        }
    }

    /// The version exchange.
    pub fn hello(&mut self) -> Result<(), ToolError> {
        match self.request(Request::Hello {
            version: PROTOCOL_VERSION,
        })? {
            Response::Hello {
                version,
                configured,
            } if version == PROTOCOL_VERSION => {
                self.configured = configured;
                Ok(())
            }
            Response::Hello { version, .. } => Err(ToolError::Version {
                device: version,
                host: PROTOCOL_VERSION,
            }),
            other => Err(anyhow::anyhow!("unexpected answer to hello: {other:?}").into()),
        }
    }

    /// Sends `req` and waits for its answer (events meanwhile are kept).
    pub fn request(&mut self, req: Request) -> Result<Response, ToolError> {
        self.seq = self.seq.wrapping_add(1);
        let seq = self.seq;
        let what = format!("{req:?}");
        self.send_raw(&HostMsg { seq, req })?;
        let deadline = Instant::now() + self.timeout;
        loop {
            match self.read_msg(deadline)? {
                Some(DeviceMsg::Response { seq: s, result }) if s == seq => {
                    return result.map_err(ToolError::from)
                }
                Some(DeviceMsg::Response { .. }) => {}
                Some(DeviceMsg::Event(e)) => self.events.push_back(e),
                Some(DeviceMsg::FrameError(e)) => return Err(ToolError::Device(e)),
                None => return Err(ToolError::Timeout(what)),
            }
        }
    }

    /// Sends `msg` as one frame.
    pub fn send_raw<M: serde::Serialize>(&mut self, msg: &M) -> Result<(), ToolError> {
        let mut buf = [0u8; MAX_FRAME];
        let n = frame::encode(msg, &mut buf)
            .map_err(|e| ToolError::Other(anyhow::anyhow!("cannot encode: {e:?}")))?;
        self.send_bytes(&buf[..n])
    }

    /// Sends raw bytes (tests: a corrupt frame).
    pub fn send_bytes(&mut self, bytes: &[u8]) -> Result<(), ToolError> {
        self.io.write_all(bytes).map_err(ToolError::Io)?;
        self.io.flush().map_err(ToolError::Io)
    }

    /// The next message from the device before `deadline` (`None`: none came).
    pub fn read_msg(&mut self, deadline: Instant) -> Result<Option<DeviceMsg>, ToolError> {
        loop {
            while self.pos < self.len {
                let b = self.buf[self.pos];
                self.pos += 1;
                if let Pushed::Frame(f) = self.rx.push(b) {
                    // A frame that does not decode on the host is dropped (the device's
                    // frames carry a checksum too).
                    if let Ok(msg) = frame::decode::<DeviceMsg>(f) {
                        return Ok(Some(msg));
                    }
                }
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
            self.pos = 0;
            self.len = match self.io.read(&mut self.buf) {
                Ok(0) => {
                    return Err(ToolError::Io(std::io::Error::new(
                        ErrorKind::UnexpectedEof,
                        "the device closed the link",
                    )))
                }
                Ok(n) => n,
                Err(e)
                    if matches!(
                        e.kind(),
                        ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
                    ) =>
                {
                    0
                }
                Err(e) => return Err(ToolError::Io(e)),
            };
        }
    }

    /// The next event, waiting up to `timeout` for one.
    pub fn next_event(&mut self, timeout: Duration) -> Result<Option<Event>, ToolError> {
        if let Some(e) = self.events.pop_front() {
            return Ok(Some(e));
        }
        let deadline = Instant::now() + timeout;
        loop {
            match self.read_msg(deadline)? {
                Some(DeviceMsg::Event(e)) => return Ok(Some(e)),
                Some(_) => {}
                None => return Ok(None),
            }
        }
    }

    /// Events received and not taken, dropped.
    pub fn clear_events(&mut self) {
        self.events.clear();
    }
}
