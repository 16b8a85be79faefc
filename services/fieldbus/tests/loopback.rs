//! The TCP gateway end to end on loopback: a real TCP client, the gateway in one thread and a
//! fake interpreter in another, over a private iceoryx2 instance per test.

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use fieldbus::Gateway;
use shared_types::bus::{Bus, publish, wait_for_wakeup};
use shared_types::config::Config;
use shared_types::ipc::{LinkEvent, PlcTelegram, RobotTelegram, TELEGRAM_CAPACITY, topics};

const LENGTH: usize = 256;
/// First request byte that makes the fake interpreter stay silent.
const NO_ANSWER: u8 = 0xFF;

/// What the fake interpreter saw on `srci/p2r`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Seen {
    event: LinkEvent,
    connection: u32,
    len: u16,
}

struct Harness {
    addr: SocketAddr,
    stop_gateway: Arc<AtomicBool>,
    stop_interpreter: Arc<AtomicBool>,
    seen: mpsc::Receiver<Seen>,
    gateway: JoinHandle<()>,
    interpreter: JoinHandle<()>,
}

impl Harness {
    /// Starts a fake interpreter, then the gateway on an ephemeral port.
    fn start(tag: &str) -> Self {
        let mut cfg = Config::load(None).expect("embedded config");
        cfg.main.instance = format!("fb{tag}{}", std::process::id());
        cfg.main.fieldbus.listen = "127.0.0.1:0".into();
        cfg.main.fieldbus.reply_timeout_ms = 50;
        let stop_gateway = Arc::new(AtomicBool::new(false));
        let stop_interpreter = Arc::new(AtomicBool::new(false));

        let (seen_tx, seen) = mpsc::channel();
        let (ready_tx, ready) = mpsc::channel();
        let interpreter = {
            let instance = cfg.main.instance.clone();
            let stop = stop_interpreter.clone();
            thread::spawn(move || fake_interpreter(&instance, &stop, &ready_tx, &seen_tx))
        };
        ready.recv().expect("fake interpreter ready");

        let (addr_tx, addr_rx) = mpsc::channel();
        let gateway = {
            let stop = stop_gateway.clone();
            thread::spawn(move || {
                let mut gateway = Gateway::bind(&cfg).expect("bind gateway");
                addr_tx.send(gateway.local_addr().expect("addr")).unwrap();
                gateway.serve(&stop).expect("serve");
            })
        };
        let addr = addr_rx.recv().expect("gateway address");
        Self {
            addr,
            stop_gateway,
            stop_interpreter,
            seen,
            gateway,
            interpreter,
        }
    }

    fn connect(&self) -> TcpStream {
        let s = TcpStream::connect(self.addr).expect("connect");
        s.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
        s
    }

    /// The next sample the interpreter saw.
    fn next_seen(&self) -> Seen {
        self.seen
            .recv_timeout(Duration::from_secs(2))
            .expect("a p2r sample")
    }

    /// Stops the gateway (checking it does so promptly), then the interpreter after it has
    /// read everything the gateway published; returns the samples not yet looked at.
    fn stop(self) -> Vec<Seen> {
        let t0 = Instant::now();
        self.stop_gateway.store(true, Ordering::Relaxed);
        self.gateway.join().expect("gateway thread");
        assert!(t0.elapsed() < Duration::from_millis(100), "slow shutdown");
        self.stop_interpreter.store(true, Ordering::Relaxed);
        self.interpreter.join().expect("interpreter thread");
        self.seen.try_iter().collect()
    }
}

/// Answers every telegram with its bytes XOR 0x5A (so an echo cannot pass for an answer),
/// except those starting with [`NO_ANSWER`].
fn fake_interpreter(
    instance: &str,
    stop: &AtomicBool,
    ready: &mpsc::Sender<()>,
    seen: &mpsc::Sender<Seen>,
) {
    let bus = Bus::new(instance, "fakeinterp").unwrap();
    let p2r = bus.subscriber::<PlcTelegram>(topics::P2R).unwrap();
    let p2r_wake = bus.listener(topics::P2R).unwrap();
    let r2p = bus.publisher::<RobotTelegram>(topics::R2P).unwrap();
    let r2p_wake = bus.notifier(topics::R2P).unwrap();
    ready.send(()).unwrap();
    loop {
        // Once told to stop, one last pass picks up whatever was published before.
        let stopping = stop.load(Ordering::Relaxed);
        if !stopping {
            wait_for_wakeup(&p2r_wake, Duration::from_millis(5)).unwrap();
        }
        while let Some(sample) = p2r.receive().unwrap() {
            let t = *sample.payload();
            let event = LinkEvent::from_wire(t.event);
            let _ = seen.send(Seen {
                event,
                connection: t.connection,
                len: t.len,
            });
            if event != LinkEvent::Telegram || t.telegram().first() == Some(&NO_ANSWER) {
                continue;
            }
            let mut reply = RobotTelegram {
                counter: t.counter,
                connection: t.connection,
                flags: 0,
                len: LENGTH as u16,
                bytes: [0; TELEGRAM_CAPACITY],
            };
            for (r, p) in reply.bytes.iter_mut().zip(t.telegram()) {
                *r = p ^ 0x5A;
            }
            publish(&r2p, reply).unwrap();
            r2p_wake.notify().unwrap();
        }
        if stopping {
            return;
        }
    }
}

fn request(fill: u8) -> [u8; LENGTH] {
    core::array::from_fn(|i| fill.wrapping_add(i as u8))
}

fn answer_to(req: &[u8; LENGTH]) -> [u8; LENGTH] {
    req.map(|b| b ^ 0x5A)
}

fn exchange(s: &mut TcpStream, req: &[u8; LENGTH]) -> [u8; LENGTH] {
    s.write_all(req).unwrap();
    let mut reply = [0u8; LENGTH];
    s.read_exact(&mut reply).expect("a full reply");
    reply
}

fn expect_silence(s: &mut TcpStream, wait: Duration) {
    s.set_read_timeout(Some(wait)).unwrap();
    let mut byte = [0u8; 1];
    match s.read(&mut byte) {
        Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
        other => panic!("expected no bytes, got {other:?}"),
    }
    s.set_read_timeout(Some(Duration::from_secs(2))).unwrap();
}

#[test]
fn a_256_byte_telegram_gets_exactly_one_256_byte_answer() {
    let h = Harness::start("echo");
    let mut client = h.connect();
    assert_eq!(
        h.next_seen(),
        Seen {
            event: LinkEvent::Connected,
            connection: 1,
            len: 0
        }
    );
    for fill in 0..20u8 {
        let req = request(fill);
        assert_eq!(exchange(&mut client, &req), answer_to(&req));
    }
    expect_silence(&mut client, Duration::from_millis(100));
    drop(client);
    let seen = h.stop();
    assert_eq!(
        seen.iter()
            .filter(|s| s.event == LinkEvent::Telegram)
            .count(),
        20
    );
    assert!(
        seen.iter()
            .all(|s| s.event != LinkEvent::Telegram || s.len == LENGTH as u16)
    );
    assert_eq!(
        seen.last(),
        Some(&Seen {
            event: LinkEvent::Disconnected,
            connection: 1,
            len: 0
        })
    );
}

#[test]
fn a_telegram_in_pieces_is_reassembled() {
    let h = Harness::start("pieces");
    let mut client = h.connect();
    client.set_nodelay(true).unwrap();
    let req = request(9);
    for chunk in req.chunks(100) {
        client.write_all(chunk).unwrap();
        thread::sleep(Duration::from_millis(15));
    }
    let mut reply = [0u8; LENGTH];
    client.read_exact(&mut reply).unwrap();
    assert_eq!(reply, answer_to(&req));
    h.stop();
}

#[test]
fn an_unanswered_request_gets_no_reply_and_later_ones_are_not_shifted() {
    let h = Harness::start("silent");
    let mut client = h.connect();
    let mut silent = request(1);
    silent[0] = NO_ANSWER;
    client.write_all(&silent).unwrap();
    expect_silence(&mut client, Duration::from_millis(150));
    let req = request(2);
    assert_eq!(exchange(&mut client, &req), answer_to(&req));
    h.stop();
}

#[test]
fn a_second_client_replaces_the_first() {
    let h = Harness::start("replace");
    let mut first = h.connect();
    assert_eq!(h.next_seen().event, LinkEvent::Connected);
    let req = request(3);
    assert_eq!(exchange(&mut first, &req), answer_to(&req));

    let mut second = h.connect();
    let mut buf = [0u8; 1];
    match first.read(&mut buf) {
        Ok(0) => {}
        Err(e) if e.kind() == ErrorKind::ConnectionReset => {}
        other => panic!("the first client should be closed, got {other:?}"),
    }
    let req = request(4);
    assert_eq!(exchange(&mut second, &req), answer_to(&req));

    let seen = h.stop();
    let events: Vec<(LinkEvent, u32)> = seen.iter().map(|s| (s.event, s.connection)).collect();
    assert_eq!(
        events,
        vec![
            (LinkEvent::Telegram, 1),
            (LinkEvent::Disconnected, 1),
            (LinkEvent::Connected, 2),
            (LinkEvent::Telegram, 2),
            (LinkEvent::Disconnected, 2),
        ]
    );
}
