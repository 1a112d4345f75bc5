//! Client and server machines wired back to back in one thread: expedited round trips per
//! second, and segmented and block transfer throughput in bytes per second; the same for the
//! USDO machines of CANopen FD (expedited, and segmented in 60-byte segments).
//!
//! Run with `cargo bench -p canola-sdo --bench transfer`.

// criterion_group! generates an undocumented public function.
#![allow(missing_docs)]

use std::hint::black_box;

use canola_frame::{Instant, NodeId};
use canola_sdo::usdo::{
    DataType, UsdoClient, UsdoClientConfig, UsdoEvent, UsdoServer, UsdoServerConfig,
};
use canola_sdo::{
    AbortCode, Access, Client, ClientConfig, Event, Method, Multiplexer, ObjectAccess, ObjectInfo,
    Server, ServerConfig,
};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

const VALUE: Multiplexer = Multiplexer::new(0x2000, 1);
const DOMAIN: Multiplexer = Multiplexer::new(0x2100, 0);
const SIZE: usize = 4096;

struct Od {
    value: [u8; 4],
    domain: Vec<u8>,
    staged: usize,
}

impl ObjectAccess for Od {
    fn info(&mut self, mux: Multiplexer) -> Result<ObjectInfo, AbortCode> {
        match mux {
            VALUE => Ok(ObjectInfo::fixed(Access::ReadWrite, 4)),
            DOMAIN => Ok(ObjectInfo::variable(
                Access::ReadWrite,
                self.domain.len() as u32,
                SIZE as u32,
            )),
            _ => Err(AbortCode::OBJECT_DOES_NOT_EXIST),
        }
    }
    fn read(&mut self, mux: Multiplexer, offset: u32, buf: &mut [u8]) -> Result<usize, AbortCode> {
        let src: &[u8] = if mux == VALUE {
            &self.value
        } else {
            &self.domain
        };
        let start = (offset as usize).min(src.len());
        let n = buf.len().min(src.len() - start);
        buf[..n].copy_from_slice(&src[start..start + n]);
        Ok(n)
    }
    fn write(&mut self, mux: Multiplexer, offset: u32, data: &[u8]) -> Result<(), AbortCode> {
        let dst: &mut [u8] = if mux == VALUE {
            &mut self.value
        } else {
            &mut self.domain
        };
        let start = offset as usize;
        dst[start..start + data.len()].copy_from_slice(data);
        self.staged = start + data.len();
        Ok(())
    }
    fn commit(&mut self, _mux: Multiplexer, _len: u32) -> Result<(), AbortCode> {
        Ok(())
    }
}

type BenchClient = Client<Vec<u8>, &'static [u8]>;

/// Runs one transfer to its end and returns the completion.
fn run(
    client: &mut BenchClient,
    server: &mut Server,
    od: &mut Od,
) -> Event<Vec<u8>, &'static [u8]> {
    let now = Instant::ZERO;
    loop {
        let mut moved = false;
        while let Some(f) = client.poll_transmit() {
            server.handle_request(now, &f, od);
            moved = true;
        }
        while let Some(f) = server.poll_transmit() {
            client.handle_response(now, &f);
            moved = true;
        }
        if !moved {
            break;
        }
    }
    match client.poll_event() {
        Some(ev @ (Event::Uploaded { .. } | Event::Downloaded { .. })) => ev,
        other => panic!("transfer failed: {other:?}"),
    }
}

/// Uploads into `sink` (cleared first) and returns it.
fn upload(
    client: &mut BenchClient,
    server: &mut Server,
    od: &mut Od,
    mux: Multiplexer,
    mut sink: Vec<u8>,
    method: Method,
) -> Vec<u8> {
    sink.clear();
    client
        .start_upload(Instant::ZERO, mux, sink, method)
        .unwrap();
    match run(client, server, od) {
        Event::Uploaded { sink, .. } => sink,
        _ => unreachable!(),
    }
}

type BenchUsdoClient = UsdoClient<Vec<u8>, &'static [u8]>;

const USDO_CLIENT: u8 = 1;
const USDO_SERVER: u8 = 5;

/// Runs one USDO transfer to its end and returns the completion.
fn run_usdo(
    client: &mut BenchUsdoClient,
    server: &mut UsdoServer,
    od: &mut Od,
) -> UsdoEvent<Vec<u8>, &'static [u8]> {
    let now = Instant::ZERO;
    loop {
        let mut moved = false;
        while let Some(f) = client.poll_transmit() {
            server.handle_request(now, USDO_CLIENT, &f, od);
            moved = true;
        }
        while let Some(f) = server.poll_transmit() {
            client.handle_response(now, USDO_SERVER, &f);
            moved = true;
        }
        if !moved {
            break;
        }
    }
    match client.poll_event() {
        Some(ev @ (UsdoEvent::Uploaded { .. } | UsdoEvent::Downloaded { .. })) => ev,
        other => panic!("USDO transfer failed: {other:?}"),
    }
}

fn usdo_upload(
    client: &mut BenchUsdoClient,
    server: &mut UsdoServer,
    od: &mut Od,
    mux: Multiplexer,
    mut sink: Vec<u8>,
) -> Vec<u8> {
    sink.clear();
    let node = NodeId::new(USDO_SERVER).unwrap();
    client.start_upload(Instant::ZERO, node, mux, sink).unwrap();
    match run_usdo(client, server, od) {
        UsdoEvent::Uploaded { sink, .. } => sink,
        _ => unreachable!(),
    }
}

static DATA: [u8; SIZE] = {
    let mut d = [0u8; SIZE];
    let mut i = 0;
    while i < SIZE {
        d[i] = (i * 7 + 3) as u8;
        i += 1;
    }
    d
};

fn benches(c: &mut Criterion) {
    let mut od = Od {
        value: [1, 2, 3, 4],
        domain: DATA.to_vec(),
        staged: 0,
    };
    let mut server = Server::new(ServerConfig::default());

    let mut client: BenchClient = Client::new(ClientConfig::default());
    let mut sink = Vec::with_capacity(SIZE);

    let mut group = c.benchmark_group("expedited");
    group.throughput(Throughput::Elements(1));
    group.bench_function("upload round trip", |b| {
        b.iter(|| {
            sink = upload(
                &mut client,
                &mut server,
                &mut od,
                VALUE,
                std::mem::take(&mut sink),
                Method::Normal,
            );
            black_box(&sink);
        });
    });
    assert_eq!(sink, [1, 2, 3, 4]);
    group.bench_function("download round trip", |b| {
        b.iter(|| {
            client
                .start_download(Instant::ZERO, VALUE, &DATA[..4], Method::Normal)
                .unwrap();
            black_box(run(&mut client, &mut server, &mut od));
        });
    });
    group.finish();

    let mut group = c.benchmark_group("4 KiB");
    group.throughput(Throughput::Bytes(SIZE as u64));
    for (name, method) in [("segmented", Method::Normal), ("block", Method::Block)] {
        group.bench_function(format!("{name} upload"), |b| {
            b.iter(|| {
                sink = upload(
                    &mut client,
                    &mut server,
                    &mut od,
                    DOMAIN,
                    std::mem::take(&mut sink),
                    method,
                );
                black_box(&sink);
            });
        });
        assert_eq!(sink, DATA);
        group.bench_function(format!("{name} download"), |b| {
            b.iter(|| {
                client
                    .start_download(Instant::ZERO, DOMAIN, &DATA[..], method)
                    .unwrap();
                black_box(run(&mut client, &mut server, &mut od));
            });
        });
    }
    group.finish();
    assert_eq!(od.domain, DATA);

    let node = NodeId::new(USDO_SERVER).unwrap();
    let mut usdo_server = UsdoServer::new(node, UsdoServerConfig::default());
    let mut usdo_client: BenchUsdoClient = UsdoClient::new(
        NodeId::new(USDO_CLIENT).unwrap(),
        UsdoClientConfig::default(),
    );
    let mut group = c.benchmark_group("expedited");
    group.throughput(Throughput::Elements(1));
    group.bench_function("usdo upload round trip", |b| {
        b.iter(|| {
            sink = usdo_upload(
                &mut usdo_client,
                &mut usdo_server,
                &mut od,
                VALUE,
                std::mem::take(&mut sink),
            );
            black_box(&sink);
        });
    });
    // The SDO download round trip above wrote the first four bytes of DATA.
    assert_eq!(sink, DATA[..4]);
    group.finish();
    let mut group = c.benchmark_group("4 KiB");
    group.throughput(Throughput::Bytes(SIZE as u64));
    group.bench_function("usdo segmented upload", |b| {
        b.iter(|| {
            sink = usdo_upload(
                &mut usdo_client,
                &mut usdo_server,
                &mut od,
                DOMAIN,
                std::mem::take(&mut sink),
            );
            black_box(&sink);
        });
    });
    assert_eq!(sink, DATA);
    group.bench_function("usdo segmented download", |b| {
        b.iter(|| {
            usdo_client
                .start_download(Instant::ZERO, node, DOMAIN, DataType::DOMAIN, &DATA[..])
                .unwrap();
            black_box(run_usdo(&mut usdo_client, &mut usdo_server, &mut od));
        });
    });
    group.finish();
    assert_eq!(od.domain, DATA);
    let _ = od.staged;
}

criterion_group!(transfer, benches);
criterion_main!(transfer);
