//! Serving a simulated device: the link's [`Server`] on any `embedded-io` stream (a TCP
//! socket through [`StdIo`], or the emulated firmware's UART in its place), the device's
//! simulated time advanced between polls, paced against the wall clock.

use crate::sim_device::SimDevice;
use pmsm_link::Server;
use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// A non-blocking `TcpStream` as an `embedded-io` stream: `read_ready` peeks, writes wait for
/// room.
pub struct StdIo(pub TcpStream);

impl embedded_io::ErrorType for StdIo {
    type Error = std::io::Error;
}

impl embedded_io::Read for StdIo {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        loop {
            match self.0.read(buf) {
                Err(e) if e.kind() == ErrorKind::WouldBlock => {
                    std::thread::sleep(Duration::from_micros(200))
                }
                // The peer closed the socket: an error, so the server's poll ends the
                // connection.
                Ok(0) if !buf.is_empty() => return Err(ErrorKind::UnexpectedEof.into()),
                r => return r,
            }
        }
    }
}

impl embedded_io::ReadReady for StdIo {
    fn read_ready(&mut self) -> Result<bool, Self::Error> {
        let mut b = [0u8; 1];
        match self.0.peek(&mut b) {
            // A closed socket reads 0 at once: ready (the read returns 0).
            Ok(_) => Ok(true),
            Err(e) if e.kind() == ErrorKind::WouldBlock => Ok(false),
            Err(e) => Err(e),
        }
    }
}

impl embedded_io::Write for StdIo {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        loop {
            match self.0.write(buf) {
                Err(e) if e.kind() == ErrorKind::WouldBlock => {
                    std::thread::sleep(Duration::from_micros(200))
                }
                r => return r,
            }
        }
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        self.0.flush()
    }
}

/// How the device's simulated time follows the wall clock.
#[derive(Clone, Copy, Debug)]
pub struct Pace {
    /// Simulated time advanced per poll of the link \[s] (the firmware's main-loop period).
    pub poll_s: f64,
    /// At most this many simulated seconds per wall-clock second (it may run slower).
    pub max_speedup: f64,
}

impl Default for Pace {
    /// A poll per simulated millisecond, at most 20× the wall clock.
    fn default() -> Self {
        Self {
            poll_s: 1e-3,
            max_speedup: 20.0,
        }
    }
}

/// Serves `device` on `io` until `stop` is set or the stream fails (the peer closed it):
/// poll the link, advance the device, as a firmware's main loop does.
pub fn serve<T>(io: &mut T, device: &Mutex<SimDevice>, pace: Pace, stop: &AtomicBool)
where
    T: embedded_io::Read + embedded_io::Write + embedded_io::ReadReady,
{
    let mut server = Server::new();
    let start = Instant::now();
    let t0 = device.lock().map(|d| d.t_s()).unwrap_or(0.0);
    while !stop.load(Ordering::Relaxed) {
        {
            let Ok(mut d) = device.lock() else { return };
            if server.poll(io, &mut *d).is_err() {
                return;
            }
            let ahead = d.t_s() - t0 - start.elapsed().as_secs_f64() * pace.max_speedup;
            if ahead < 0.0 {
                d.advance(pace.poll_s);
                continue;
            }
        }
        std::thread::sleep(Duration::from_micros(500));
    }
}

/// A simulated device served on a local TCP port: its address, the device (to reset it or
/// look at its plant), and the thread's stop flag (set on drop).
pub struct Served {
    /// `127.0.0.1:port`.
    pub addr: String,
    /// The device.
    pub device: Arc<Mutex<SimDevice>>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Served {
    /// Serves `device` on a free local port, one connection after another.
    pub fn spawn(device: SimDevice, pace: Pace) -> anyhow::Result<Self> {
        let listener = TcpListener::bind("127.0.0.1:0")?;
        Self::spawn_on(listener, device, pace)
    }

    /// Serves `device` on `listener`, one connection after another.
    pub fn spawn_on(listener: TcpListener, device: SimDevice, pace: Pace) -> anyhow::Result<Self> {
        let addr = listener.local_addr()?.to_string();
        listener.set_nonblocking(true)?;
        let device = Arc::new(Mutex::new(device));
        let stop = Arc::new(AtomicBool::new(false));
        let (d, s) = (device.clone(), stop.clone());
        let thread = std::thread::spawn(move || {
            while !s.load(Ordering::Relaxed) {
                match listener.accept() {
                    Ok((stream, _)) => {
                        let _ = stream.set_nonblocking(true);
                        let _ = stream.set_nodelay(true);
                        serve(&mut StdIo(stream), &d, pace, &s);
                    }
                    Err(_) => std::thread::sleep(Duration::from_millis(2)),
                }
            }
        });
        Ok(Self {
            addr,
            device,
            stop,
            thread: Some(thread),
        })
    }

    /// Stops serving and waits for the thread.
    pub fn stop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Served {
    fn drop(&mut self) {
        self.stop();
    }
}
