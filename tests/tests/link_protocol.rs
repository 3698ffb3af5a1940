//! The postcard link end to end over a real socket, against the host's virtual flight
//! computer (the same `Session` the firmware runs): the framed run must reproduce the
//! in-process run bit for bit, and corrupt bytes on the wire must be dropped, counted and
//! survived.

use acs_flight::link::{FswMsg, HostMsg};
use acs_tests::{corrupt_frames_are_dropped_and_counted, run_in_process, scenario};
use sim_core::link::framed::Framed;
use sim_core::link::{FlightLink, serve};
use std::net::{TcpListener, TcpStream};

fn virtual_board() -> Framed<TcpStream> {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = l.local_addr().unwrap();
    std::thread::spawn(move || serve::serve(l, Some(1)));
    Framed::tcp(&addr.to_string()).unwrap()
}

#[test]
fn framed_tcp_run_equals_in_process_run_bit_for_bit() {
    let mut sc = scenario("paper000/test3.toml");
    sc.duration_s = 8.0;
    sc.sensors.attitude_noise_deg = 0.5;
    let a = run_in_process(&sc);
    let mut link = virtual_board();
    let b = sim_core::runner::run(&sc, &mut link, false).unwrap();
    for name in ["q_w", "yaw_deg", "gimbal1_deg", "gimbal_rate3_rad_s", "torque_demand_z_nm", "singularity_m"] {
        let (x, y) = (a.series.col(name).unwrap(), b.series.col(name).unwrap());
        assert!(x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits()), "column {name} differs");
    }
    assert_eq!(b.summary.frames_dropped_flight, 0);
    assert_eq!(b.summary.frames_dropped_host, 0);
}

#[test]
fn corrupt_frames_on_the_wire_are_dropped_counted_and_survived() {
    let mut link = virtual_board();
    corrupt_frames_are_dropped_and_counted(&mut link);
}

#[test]
fn repeated_frames_and_trailing_junk_are_refused_not_stepped() {
    let mut link = virtual_board();
    acs_tests::repeated_frames_and_trailing_junk_are_refused(&mut link);
}

#[test]
fn rejected_parameters_and_version_mismatch_are_reported() {
    let mut link = virtual_board();
    link.hello().unwrap();
    let mut p = acs_flight::params::FlightParams::default();
    p.inertia_kgm2[1][1] = -3.0;
    let e = format!("{:#}", link.upload(&p).unwrap_err());
    assert!(e.contains("Inertia"), "{e}");
    link.send(&HostMsg::Hello { protocol_version: 999, schema_hash: 0 }).unwrap();
    assert!(matches!(link.recv().unwrap(), FswMsg::Error(_)));
}
