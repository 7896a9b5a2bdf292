//! Cdios 6168 test vectors. Byte layouts are the manual's "Command" tables
//! (section per command code); ids are the specs README's transport.

use super::table::{self, Kind, COMMANDS};
use super::transport::{self, classify_code, BusMessage};
use super::*;
use crate::proto::CanFrame;
use proptest::prelude::*;
use std::collections::BTreeSet;

fn m(id: u8) -> Address {
    Address::Module(ModuleId::new(id).unwrap())
}

fn node1() -> NodeId {
    NodeId::new(1).unwrap()
}

fn hex(data: &[u8]) -> String {
    data.iter().map(|b| format!("{b:02X}")).collect::<Vec<_>>().join(" ")
}

fn frame(s: &str) -> CanFrame {
    s.parse().unwrap()
}

// The CLI contract: `cdios-goto -m 1 --node 1 5000` is id 0x201, 23 01 00 88 13 00 00 00.
// Manual 23h: selector 0 = "Move motor absolute to the given position", bytes 4..7 the position.
#[test]
fn contract_goto_vector() {
    let cmd = Command::Goto { mode: GotoMode::Absolute, position: 5000 };
    let f = cmd.frame(node1(), m(1)).unwrap();
    assert_eq!(f.id(), 0x201);
    assert_eq!(f.to_string(), "201#2301008813000000");
    assert_eq!(Command::decode(f.data()), Ok((m(1), cmd)));
}

// Specs README: NMT start `id 0x000, [0x01, node]`; commands on 0x200 + node, answers on 0x180 + node.
#[test]
fn transport_ids() {
    assert_eq!(transport::nmt_start(node1()).to_string(), "000#0101");
    assert_eq!(transport::nmt_start(NodeId::new(127).unwrap()).to_string(), "000#017F");
    assert_eq!(transport::command_frame(NodeId::new(5).unwrap(), &[0x26, 0, 0, 0, 0, 0, 0, 0]).id(), 0x205);
    assert_eq!(transport::answer_frame(NodeId::new(127).unwrap(), &[0; 8]).id(), 0x1FF);
    assert_eq!(NodeId::new(0), None);
    assert_eq!(NodeId::new(128), None);
    assert_eq!(NodeId::try_from(0), Err(ValidationError::Node(0)));
    assert_eq!(ModuleId::new(16), None);
    assert_eq!(ModuleId::try_from(16), Err(ValidationError::Module(16)));
    assert_eq!(Address::from_byte(0x10), Address::Controller);
    assert_eq!(Address::from_byte(15), m(15));
    assert_eq!(Address::Controller.to_byte(), 0xFF);
}

/// One vector per command layout and selector family, to module 1 unless
/// the controller. Expected bytes are written out from the manual's tables.
fn vectors() -> Vec<(Command, Address, &'static str)> {
    use ServoConfig as S;
    let c = Address::Controller;
    vec![
        // 01h (controller documentation): [01 FF selector 0 0 0 0 0]
        (Command::Identify { selector: 0 }, c, "01 FF 00 00 00 00 00 00"),
        (Command::Identify { selector: 24 }, c, "01 FF 18 00 00 00 00 00"),
        // 05h: selector, then 43h 44h 53h
        (Command::StoreConfiguration { defaults: false }, m(1), "05 01 00 43 44 53 00 00"),
        (Command::StoreConfiguration { defaults: true }, m(1), "05 01 01 43 44 53 00 00"),
        // 10h set: selector 0 direct / 1 latched, data bits 0..3
        (Command::SetDigitalOutputs { latched: false, outputs: 0b1010 }, m(1), "10 01 00 0A 00 00 00 00"),
        (Command::SetDigitalOutputs { latched: true, outputs: 0b0101 }, m(3), "10 03 01 05 00 00 00 00"),
        // 10h get: selector 80h
        (Command::GetDigitalOutputs, m(1), "10 01 80 00 00 00 00 00"),
        // 16h set: selector 00h/01h/10h/11h, data int16 in bytes 4-5
        (
            Command::SetAnalogOutput { output: AnalogOutput::One, latched: false, millivolts: -10000 },
            m(1),
            "16 01 00 F0 D8 00 00 00",
        ),
        (
            Command::SetAnalogOutput { output: AnalogOutput::One, latched: true, millivolts: 1 },
            m(1),
            "16 01 01 01 00 00 00 00",
        ),
        (
            Command::SetAnalogOutput { output: AnalogOutput::Two, latched: false, millivolts: 2500 },
            m(1),
            "16 01 10 C4 09 00 00 00",
        ),
        (
            Command::SetAnalogOutput { output: AnalogOutput::Two, latched: true, millivolts: 10000 },
            m(1),
            "16 01 11 10 27 00 00 00",
        ),
        // 16h read: 80h / 90h
        (Command::ReadAnalogOutput { output: AnalogOutput::One }, m(1), "16 01 80 00 00 00 00 00"),
        (Command::ReadAnalogOutput { output: AnalogOutput::Two }, m(1), "16 01 90 00 00 00 00 00"),
        // 20h set, defaults of the manual's table
        (
            Command::SetServoConfig(S::Speeds { minimum_speed: 50, maximum_speed: 8000, slope: 10 }),
            m(1),
            "20 01 00 32 00 40 1F 0A",
        ),
        (
            Command::SetServoConfig(S::Voltage {
                maximum_voltage: 10000,
                forward_end_switch: true,
                reverse_end_switch: false,
            }),
            m(1),
            "20 01 01 10 27 01 00 00",
        ),
        (
            Command::SetServoConfig(S::Encoder {
                pulses_per_revolution: 500,
                hold_on_enable: true,
                auto_zero: false,
                sin2_slope: true,
            }),
            m(1),
            "20 01 02 F4 01 01 00 01",
        ),
        (
            Command::SetServoConfig(S::Control { positioning_error: 25, gain_factor: 32, d_factor: 32, failsafe: 63 }),
            m(1),
            "20 01 03 19 00 20 20 3F",
        ),
        (Command::SetServoConfig(S::Inputs { ready_input: true, error_input: true }), m(1), "20 01 04 00 00 01 01 00"),
        (
            Command::SetServoConfig(S::TrajectEnd { traject: Traject::Zero, end_position: 100000, length: 2 }),
            m(1),
            "20 01 10 A0 86 01 00 02",
        ),
        (
            Command::SetServoConfig(S::TrajectEnd { traject: Traject::One, end_position: -1000, length: 4 }),
            m(1),
            "20 01 20 18 FC FF FF 04",
        ),
        (
            Command::SetServoConfig(S::TrajectInitialSpeed { traject: Traject::Zero, speed: 300 }),
            m(1),
            "20 01 11 2C 01 00 00 00",
        ),
        (
            Command::SetServoConfig(S::TrajectInitialSpeed { traject: Traject::One, speed: 32767 }),
            m(1),
            "20 01 21 FF 7F 00 00 00",
        ),
        (
            Command::SetServoConfig(S::TrajectChangePosition {
                traject: Traject::Zero,
                step: Step::First,
                position: 1,
            }),
            m(1),
            "20 01 12 01 00 00 00 00",
        ),
        (
            Command::SetServoConfig(S::TrajectChangePosition {
                traject: Traject::Zero,
                step: Step::Third,
                position: 123456,
            }),
            m(1),
            "20 01 16 40 E2 01 00 00",
        ),
        (
            Command::SetServoConfig(S::TrajectChangePosition {
                traject: Traject::One,
                step: Step::Second,
                position: -1,
            }),
            m(1),
            "20 01 24 FF FF FF FF 00",
        ),
        (
            Command::SetServoConfig(S::TrajectSpeed { traject: Traject::Zero, step: Step::First, speed: 1000 }),
            m(1),
            "20 01 13 E8 03 00 00 00",
        ),
        (
            Command::SetServoConfig(S::TrajectSpeed { traject: Traject::One, step: Step::Third, speed: 7 }),
            m(1),
            "20 01 27 07 00 00 00 00",
        ),
        // 20h read: 80h..84h, 90h..97h, A0h..A7h
        (Command::ReadServoConfig(ServoPart::Speeds), m(1), "20 01 80 00 00 00 00 00"),
        (Command::ReadServoConfig(ServoPart::Voltage), m(1), "20 01 81 00 00 00 00 00"),
        (Command::ReadServoConfig(ServoPart::Encoder), m(1), "20 01 82 00 00 00 00 00"),
        (Command::ReadServoConfig(ServoPart::Control), m(1), "20 01 83 00 00 00 00 00"),
        (Command::ReadServoConfig(ServoPart::Inputs), m(1), "20 01 84 00 00 00 00 00"),
        (Command::ReadServoConfig(ServoPart::TrajectEnd(Traject::Zero)), m(1), "20 01 90 00 00 00 00 00"),
        (Command::ReadServoConfig(ServoPart::TrajectInitialSpeed(Traject::One)), m(1), "20 01 A1 00 00 00 00 00"),
        (
            Command::ReadServoConfig(ServoPart::TrajectChangePosition(Traject::Zero, Step::Second)),
            m(1),
            "20 01 94 00 00 00 00 00",
        ),
        (Command::ReadServoConfig(ServoPart::TrajectSpeed(Traject::One, Step::Third)), m(1), "20 01 A7 00 00 00 00 00"),
        // 21h: selector 0..2
        (Command::ReadPosition(PositionSource::Current), m(0), "21 00 00 00 00 00 00 00"),
        (Command::ReadPosition(PositionSource::Setpoint), m(1), "21 01 02 00 00 00 00 00"),
        // 22h: 0, int32 position in bytes 4..7
        (Command::SetPosition { position: -1200 }, m(1), "22 01 00 50 FB FF FF 00"),
        // 23h: selectors 0..10
        (Command::Goto { mode: GotoMode::Relative, position: -5000 }, m(1), "23 01 02 78 EC FF FF 00"),
        (Command::Goto { mode: GotoMode::SetpointRelativeSync, position: i32::MAX }, m(1), "23 01 05 FF FF FF 7F 00"),
        (Command::GotoTraject { traject: Traject::One, sync: false }, m(1), "23 01 06 01 00 00 00 00"),
        (Command::GotoTraject { traject: Traject::Zero, sync: true }, m(1), "23 01 07 00 00 00 00 00"),
        (Command::SetNextGotoSpeed { speed: 1000 }, m(1), "23 01 08 E8 03 00 00 00"),
        (Command::SetSpeedChangePosition { position: 20000 }, m(1), "23 01 09 20 4E 00 00 00"),
        (Command::ChangeGotoSpeed { speed: 32767 }, m(1), "23 01 0A FF 7F 00 00 00"),
        // 24h: selector, direction, option, MotorSpeed in bytes 6-7
        (
            Command::Start {
                sync: false,
                direction: Direction::Reverse,
                option: StartOption::ToSpeed,
                motor_speed: 30000,
            },
            m(1),
            "24 01 00 01 03 30 75 00",
        ),
        (
            Command::Start { sync: true, direction: Direction::Forward, option: StartOption::Enable, motor_speed: 0 },
            m(1),
            "24 01 01 00 05 00 00 00",
        ),
        // 25h: selector, option
        (Command::Stop { sync: false, option: StopOption::ReleaseEmergency }, m(1), "25 01 00 03 00 00 00 00"),
        (Command::Stop { sync: true, option: StopOption::FastStop }, m(1), "25 01 01 02 00 00 00 00"),
        // 26h: selector 0..2
        (Command::ReadStatus(StatusSelector::Status), m(1), "26 01 00 00 00 00 00 00"),
        (Command::ReadStatus(StatusSelector::Speed), m(1), "26 01 01 00 00 00 00 00"),
        (Command::ReadStatus(StatusSelector::SpeedError), m(1), "26 01 02 00 00 00 00 00"),
        // 27h: 0, mask 1..4, timers (bits 0-2, 3, 4-6, 7)
        (
            Command::SetEventMask {
                masks: [0xFF, 0x3F, 0x80, 0x01],
                timers: Timers {
                    position_interval: 5,
                    position_on_change: true,
                    speed_interval: 7,
                    speed_on_change: false,
                },
            },
            m(1),
            "27 01 00 FF 3F 80 01 7D",
        ),
        (
            Command::SetEventMask {
                masks: [0; 4],
                timers: Timers {
                    position_interval: 0,
                    position_on_change: false,
                    speed_interval: 1,
                    speed_on_change: true,
                },
            },
            m(1),
            "27 01 00 00 00 00 00 90",
        ),
        (Command::ReadEventMask, m(1), "27 01 80 00 00 00 00 00"),
    ]
}

#[test]
fn every_command_vector() {
    for (cmd, addr, want) in vectors() {
        let data = cmd.encode(addr).unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
        assert_eq!(hex(&data), want, "{cmd:?}");
        assert_eq!(Command::decode(&data), Ok((addr, cmd)), "{want}");
        assert_eq!(cmd.def().code, data[0]);
    }
}

#[test]
fn vectors_cover_every_table_row() {
    let used: BTreeSet<&str> = vectors().iter().map(|(c, ..)| c.def().key).collect();
    let all: BTreeSet<&str> = COMMANDS.iter().map(|c| c.key).collect();
    assert_eq!(used, all);
}

#[test]
fn validation_rejects_out_of_range() {
    use ServoConfig as S;
    let bad = |cmd: Command, addr: Address| cmd.encode(addr).unwrap_err();
    let range = |e: ValidationError| match e {
        ValidationError::OutOfRange { field, .. } => field,
        other => panic!("{other:?}"),
    };
    assert_eq!(range(bad(Command::SetDigitalOutputs { latched: false, outputs: 16 }, m(0))), "outputs");
    let analog = |mv| Command::SetAnalogOutput { output: AnalogOutput::One, latched: false, millivolts: mv };
    assert_eq!(range(bad(analog(10001), m(0))), "value");
    assert_eq!(range(bad(analog(-10001), m(0))), "value");
    let speeds = |a, b, c| Command::SetServoConfig(S::Speeds { minimum_speed: a, maximum_speed: b, slope: c });
    assert_eq!(range(bad(speeds(0, 8000, 10), m(0))), "minimum_speed");
    assert_eq!(range(bad(speeds(2501, 8000, 10), m(0))), "minimum_speed");
    assert_eq!(range(bad(speeds(50, 49, 10), m(0))), "maximum_speed");
    assert_eq!(range(bad(speeds(50, 32001, 10), m(0))), "maximum_speed");
    assert_eq!(range(bad(speeds(50, 8000, 0), m(0))), "slope");
    assert!(speeds(2500, 32000, 255).encode(m(0)).is_ok());
    let voltage = |v| {
        Command::SetServoConfig(S::Voltage { maximum_voltage: v, forward_end_switch: true, reverse_end_switch: true })
    };
    assert_eq!(range(bad(voltage(999), m(0))), "maximum_voltage");
    assert_eq!(range(bad(voltage(10001), m(0))), "maximum_voltage");
    let ppr = |p| {
        Command::SetServoConfig(S::Encoder {
            pulses_per_revolution: p,
            hold_on_enable: false,
            auto_zero: false,
            sin2_slope: false,
        })
    };
    assert_eq!(range(bad(ppr(0), m(0))), "pulses_per_revolution");
    assert_eq!(range(bad(ppr(10001), m(0))), "pulses_per_revolution");
    let control = |e, g, f| {
        Command::SetServoConfig(S::Control { positioning_error: e, gain_factor: g, d_factor: 0, failsafe: f })
    };
    assert_eq!(range(bad(control(10001, 1, 0), m(0))), "positioning_error");
    assert_eq!(range(bad(control(0, 0, 0), m(0))), "gain_factor");
    assert_eq!(range(bad(control(0, 1, 64), m(0))), "failsafe");
    let traject = S::TrajectEnd { traject: Traject::Zero, end_position: 0, length: 5 };
    assert_eq!(range(bad(Command::SetServoConfig(traject), m(0))), "length");
    let initial = S::TrajectInitialSpeed { traject: Traject::Zero, speed: 32768 };
    assert_eq!(range(bad(Command::SetServoConfig(initial), m(0))), "initial_speed");
    let speed = S::TrajectSpeed { traject: Traject::One, step: Step::First, speed: 40000 };
    assert_eq!(range(bad(Command::SetServoConfig(speed), m(0))), "speed");
    assert_eq!(range(bad(Command::SetNextGotoSpeed { speed: 32768 }, m(0))), "speed");
    assert_eq!(range(bad(Command::ChangeGotoSpeed { speed: 65535 }, m(0))), "speed");
    let start =
        Command::Start { sync: false, direction: Direction::Forward, option: StartOption::ToSpeed, motor_speed: 30001 };
    assert_eq!(range(bad(start, m(0))), "motor_speed");
    let timers = Timers { position_interval: 8, ..Timers::default() };
    assert_eq!(range(bad(Command::SetEventMask { masks: [0; 4], timers }, m(0))), "position_interval");
    let timers = Timers { speed_interval: 9, ..Timers::default() };
    assert_eq!(range(bad(Command::SetEventMask { masks: [0; 4], timers }, m(0))), "speed_interval");

    assert!(matches!(bad(Command::Identify { selector: 25 }, Address::Controller), ValidationError::Selector { .. }));
    assert!(matches!(bad(Command::Identify { selector: 0 }, m(0)), ValidationError::Address { .. }));
    let goto = Command::Goto { mode: GotoMode::Absolute, position: 0 };
    assert!(matches!(bad(goto, Address::Controller), ValidationError::Address { .. }));
}

#[test]
fn generic_encoder_checks_keys_and_selectors() {
    let goto = table::command("goto").unwrap();
    assert_eq!(hex(&table::encode(goto, m(2), 4, &[("position", 256)]).unwrap()), "23 02 04 00 01 00 00 00");
    assert!(matches!(table::encode(goto, m(2), 6, &[("position", 1)]), Err(ValidationError::Selector { .. })));
    assert!(matches!(table::encode(goto, m(2), 0, &[]), Err(ValidationError::MissingField { .. })));
    assert!(matches!(
        table::encode(goto, m(2), 0, &[("position", 1), ("speed", 2)]),
        Err(ValidationError::UnknownField { .. })
    ));
    assert!(matches!(
        table::encode(goto, m(2), 0, &[("position", i64::from(i32::MAX) + 1)]),
        Err(ValidationError::OutOfRange { .. })
    ));
    // The 05h key bytes are constants, not inputs.
    let store = table::command("store_configuration").unwrap();
    assert!(matches!(table::encode(store, m(0), 0, &[("key_c", 0x43)]), Err(ValidationError::UnknownField { .. })));
}

#[test]
fn command_decode_rejects_what_a_module_rejects() {
    assert_eq!(Command::decode(&[]), Err(ValidationError::Empty));
    assert_eq!(Command::decode(&[0x30, 0]), Err(ValidationError::UnknownCode(0x30)));
    assert!(matches!(Command::decode(&[0x21, 1, 3]), Err(ValidationError::Selector { .. })));
    assert!(matches!(Command::decode(&[0x20, 1, 0x85]), Err(ValidationError::Selector { .. })));
    assert!(matches!(Command::decode(&[0x20, 1, 0x18]), Err(ValidationError::Selector { .. })));
    // 05h without its 43h 44h 53h key.
    assert!(matches!(Command::decode(&[0x05, 1, 0, 0x43, 0x44]), Err(ValidationError::OutOfRange { .. })));
    // Start option 7.
    assert!(matches!(Command::decode(&[0x24, 1, 0, 0, 7]), Err(ValidationError::OutOfRange { .. })));
    // Identify belongs to the controller, motion to a module.
    assert!(matches!(Command::decode(&[0x01, 3, 0]), Err(ValidationError::Address { .. })));
    assert!(matches!(Command::decode(&[0x26, 0xFF, 0]), Err(ValidationError::Address { .. })));
    // A short command reads as zero padded.
    assert_eq!(Command::decode(&[0x26, 4]), Ok((m(4), Command::ReadStatus(StatusSelector::Status))));
}

// Specs README: reply = same code, event = code | 0x40, error = code | 0x80;
// 10h/80h answers 11h; 16h errors may come as 56h (as printed) or 96h.
#[test]
fn answer_classification() {
    use AnswerKind::*;
    assert_eq!(classify_code(0x23), (Reply, 0x23));
    assert_eq!(classify_code(0x63), (Event, 0x23));
    assert_eq!(classify_code(0xA3), (Error, 0x23));
    assert_eq!(classify_code(0x11), (Reply, 0x10));
    assert_eq!(classify_code(0x90), (Error, 0x10));
    assert_eq!(classify_code(0x56), (Error, 0x16));
    assert_eq!(classify_code(0x96), (Error, 0x16));
    assert_eq!(classify_code(0x16), (Reply, 0x16));
    assert_eq!(classify_code(0x66), (Event, 0x26));
    assert_eq!(classify_code(0x81), (Error, 0x01));

    let a = Answer::from_frame(&frame("181#2301000000000000")).unwrap().unwrap();
    assert_eq!((a.node, a.kind, a.command, a.module, a.dlc), (node1(), Reply, 0x23, 1, 8));
    assert!(a.answers(0x23, 1));
    assert!(!a.answers(0x23, 2));
    let r = Answer::from_frame(&frame("18A#1103000C")).unwrap().unwrap();
    assert_eq!((r.node.get(), r.kind, r.command, r.module, r.dlc), (10, Reply, 0x10, 3, 4));
    assert_eq!(r.reply().unwrap().unwrap().get("state"), Some(12));

    for foreign in ["201#2301008813000000", "180#2300", "200#00", "17F#2300", "0A1#00"] {
        assert_eq!(Answer::from_frame(&frame(foreign)), Ok(None), "{foreign}");
    }
    assert_eq!(Answer::from_frame(&frame("00000181#2300")), Ok(None));
    assert!(Answer::from_frame(&frame("181#")).is_err());
}

#[test]
fn bus_classification() {
    assert_eq!(transport::classify(&frame("000#0101")), Ok(Some(BusMessage::Nmt { command: 1, node: 1 })));
    assert!(transport::classify(&frame("000#01")).is_err());
    let Ok(Some(BusMessage::Command { node, data })) = transport::classify(&frame("201#23010088130000")) else {
        panic!("command frame")
    };
    assert_eq!(node, node1());
    assert_eq!(data, [0x23, 1, 0, 0x88, 0x13, 0, 0, 0]);
    assert!(matches!(transport::classify(&frame("181#2301")), Ok(Some(BusMessage::Answer(_)))));
    assert_eq!(transport::classify(&frame("0F1#01")), Ok(None));
}

// Manual 23h error A3h: status bit 1 emergency, bit 7 motor not enabled.
#[test]
fn goto_error_bits() {
    let a = Answer::from_frame(&frame("181#A301000082000000")).unwrap().unwrap();
    assert_eq!(a.kind, AnswerKind::Error);
    assert!(a.reply().is_none());
    let e = a.error().unwrap();
    assert_eq!((e.command, e.module, e.general, e.status1, e.status2), (0x23, 1, 0, 0x82, 0));
    let names: Vec<_> = e.flags().iter().map(|f| f.name).collect();
    assert_eq!(names, ["EMERGENCY", "MOTOR_NOT_ENABLED"]);
    assert!(e.unknown_bits().is_empty());
    assert_eq!(e.to_data(), a.data);
    assert!(e.describe().contains("motor is not enabled"), "{}", e.describe());
}

// Manual 24h error A4h: status1 bit 3 selector, status2 bit 7 motor not enabled.
#[test]
fn start_error_uses_both_status_bytes() {
    let e = ErrorReply::decode(&[0xA4, 0, 0, 0, 0x08, 0x80, 0, 0]).unwrap();
    let names: Vec<_> = e.flags().iter().map(|f| f.name).collect();
    assert_eq!(names, ["SELECTOR_OUT_OF_RANGE", "MOTOR_NOT_ENABLED"]);
    assert_eq!(e.flags()[1].byte, 2);
}

// Manual 20h error A0h: both status bytes, bits 6/7 of status 1 have two meanings.
#[test]
fn servo_config_error_bits() {
    let e = ErrorReply::decode(&[0xA0, 2, 0, 0, 0x41, 0xC0, 0, 0]).unwrap();
    let names: Vec<_> = e.flags().iter().map(|f| f.name).collect();
    assert_eq!(
        names,
        ["MOTOR_RUNNING", "HOLD_ON_ENABLE_OR_READY_OUT_OF_RANGE", "FAILSAFE_OUT_OF_RANGE", "TRAJECT_OUT_OF_RANGE"]
    );
}

// Manual 16h prints the error as 56h; the general rule gives 96h. Both are 16h errors.
#[test]
fn analog_error_as_printed_and_by_rule() {
    for code in [0x56, 0x96] {
        let a = Answer::from_data(node1(), &[code, 0, 0, 0, 0x80]).unwrap();
        assert_eq!((a.kind, a.command), (AnswerKind::Error, 0x16));
        let e = a.error().unwrap();
        assert_eq!(e.code, code);
        let names: Vec<_> = e.flags().iter().map(|f| f.name).collect();
        assert_eq!(names, ["MOTOR_ENABLED"]);
    }
}

#[test]
fn general_error_codes() {
    let e = ErrorReply::decode(&[0xA3, 5, 0, 1, 0, 0, 0, 0]).unwrap();
    assert_eq!(e.general_error(), Some(("NO_MODULE", "no module at that module id")));
    assert!(e.flags().is_empty());
    assert!(e.describe().contains("no module"));
    assert_eq!(table::general_error(8).unwrap().0, "EEPROM_BUSY");
    assert_eq!(table::general_error(4).unwrap().0, "INITIALISING");
    let odd = ErrorReply::decode(&[0xA5, 0, 0, 9, 0x20, 0, 0, 0]).unwrap();
    assert_eq!(odd.general_error(), None);
    assert!(odd.describe().contains("general error code 9"));
    // Stop error status 1 bits 5-6 are reserved.
    assert_eq!(odd.unknown_bits(), [(1, 5)]);
    assert!(ErrorReply::decode(&[0x23, 0]).is_err());
    assert_eq!(ErrorReply::new(0x25, 3, 0, 0x14, 0).to_data(), [0xA5, 3, 0, 0, 0x14, 0, 0, 0]);
}

#[test]
fn replies_decode_to_named_fields() {
    // 21h reply: selector copy, int32 position.
    let r = table::decode_reply(&[0x21, 0, 0, 0x50, 0xFB, 0xFF, 0xFF, 0]).unwrap();
    assert_eq!(r.def.unwrap().key, "read_position");
    assert_eq!(r.get("position"), Some(-1200));
    // 16h read reply: selector copy, int16 mV.
    let r = table::decode_reply(&[0x16, 1, 0x90, 0x10, 0x27, 0, 0, 0]).unwrap();
    assert_eq!(r.def.unwrap().key, "read_analog_output");
    assert_eq!(r.fields[0].raw, 10000);
    assert_eq!(r.fields[0].value, Some(10.0));
    assert_eq!(r.fields[0].value_unit, Some("V"));
    // 16h confirmation.
    let r = table::decode_reply(&[0x16, 1]).unwrap();
    assert_eq!(r.def.unwrap().key, "set_analog_output");
    assert!(r.fields.is_empty());
    // 20h read reply 80h -> typed configuration; slope 10 = 1.0 s.
    let r = table::decode_reply(&[0x20, 1, 0x80, 0x32, 0x00, 0x40, 0x1F, 0x0A]).unwrap();
    assert_eq!(r.def.unwrap().key, "read_servo_speeds");
    assert_eq!(r.fields[2].value, Some(1.0));
    assert_eq!(
        ServoConfig::from_reply(&r),
        Ok(ServoConfig::Speeds { minimum_speed: 50, maximum_speed: 8000, slope: 10 })
    );
    let r = table::decode_reply(&[0x20, 1, 0xA6, 0x18, 0xFC, 0xFF, 0xFF, 0]).unwrap();
    assert_eq!(
        ServoConfig::from_reply(&r),
        Ok(ServoConfig::TrajectChangePosition { traject: Traject::One, step: Step::Third, position: -1000 })
    );
    // A confirmation is no configuration.
    assert!(ServoConfig::from_reply(&table::decode_reply(&[0x20, 1]).unwrap()).is_err());
    // 26h selector 2: MotorSpeed, RPM_Error.
    let r = table::decode_reply(&[0x26, 1, 2, 0xE8, 0x03, 0x38, 0xFF, 0]).unwrap();
    assert_eq!((r.get("motor_speed"), r.get("rpm_error")), (Some(1000), Some(-200)));
    // 27h read reply.
    let r = table::decode_reply(&[0x27, 1, 0x80, 0xFF, 0, 0, 0, 0x7D]).unwrap();
    assert_eq!(r.get("mask1"), Some(0xFF));
    assert_eq!(r.get("position_interval"), Some(5));
    assert_eq!(r.get("position_on_change"), Some(1));
    assert_eq!(r.get("speed_interval"), Some(7));
    assert_eq!(r.get("speed_on_change"), Some(0));
    // 01h: type / version of modules 2s, 2s+1.
    let r = table::decode_reply(&[0x01, 0xFF, 3, 0x44, 0x21, 0, 0, 0]).unwrap();
    assert_eq!(r.def.unwrap().key, "identify");
    assert_eq!((r.get("first_type"), r.get("first_version")), (Some(0x44), Some(0x21)));
    let r = table::decode_reply(&[0x01, 0xFF, 20, 1, 2, 3, 4, 5]).unwrap();
    assert_eq!(r.def.unwrap().key, "identify_table");
    assert_eq!(r.get("byte8"), Some(5));
    // A selector no row echoes: no row, the raw bytes stay with the answer.
    let r = table::decode_reply(&[0x21, 0, 7, 0, 0, 0, 0, 0]).unwrap();
    assert_eq!(r.def, None);
    // An out-of-range value is reported, not rejected.
    let r = table::decode_reply(&[0x16, 0, 0x80, 0x11, 0x27, 0, 0, 0]).unwrap();
    assert_eq!((r.fields[0].raw, r.fields[0].in_range), (10001, false));
    // Unknown codes decode with no row.
    let r = table::decode_reply(&[0x3F, 0, 0]).unwrap();
    assert_eq!(r.def, None);
    assert!(table::decode_reply(&[0xA3]).is_err());
    let json = serde_json::to_value(table::decode_reply(&[0x21, 0, 0, 5, 0, 0, 0, 0]).unwrap()).unwrap();
    assert_eq!(json["def"], "read_position");
    assert_eq!(json["fields"][0]["key"], "position");
    assert_eq!(json["fields"][0]["raw"], 5);
}

// Events carry the reply layout of their command (position and status timers of 27h).
#[test]
fn events_decode_with_reply_layout() {
    let a = Answer::from_data(node1(), &[0x66, 0, 0, 0x81, 0, 0x80, 0]).unwrap();
    assert_eq!((a.kind, a.command), (AnswerKind::Event, 0x26));
    let r = a.reply().unwrap().unwrap();
    assert_eq!(r.def.unwrap().key, "read_status");
    let status = [r.get("status1"), r.get("status2"), r.get("status3"), r.get("status4")].map(|v| v.unwrap() as u8);
    assert_eq!(decode_status(status).flags, ["RUNNING_FORWARD", "GOTO_ACTIVE", "ENABLED"]);
    let p = Answer::from_data(node1(), &[0x61, 0, 0, 0x88, 0x13]).unwrap().reply().unwrap().unwrap();
    assert_eq!(p.get("position"), Some(5000));
}

// Manual 26h status bits.
#[test]
fn status_bytes_decode_bit_by_bit() {
    let s = decode_status([0x81, 0x24, 0x80, 0x80]);
    assert_eq!(
        s.flags,
        [
            "RUNNING_FORWARD",
            "GOTO_ACTIVE",
            "EMERGENCY_INPUT_ACTIVE",
            "EMERGENCY_STOP",
            "ENABLED",
            "POSITION_NOT_INITIALIZED"
        ]
    );
    assert_eq!(s.errors, ["EMERGENCY_INPUT_ACTIVE", "EMERGENCY_STOP"]);
    assert!(s.reserved.is_empty());
    let s = decode_status([0, 0, 0x0A, 0x42]);
    assert_eq!(s.reserved, [(3, 1), (3, 3), (4, 1), (4, 6)]);
    assert!(s.flags.is_empty());
    let all = decode_status([0xFF; 4]);
    assert_eq!(all.flags.len(), table::STATUS_FLAGS.len());
    assert_eq!(all.flags.len() + all.reserved.len(), 32);
    let json = serde_json::to_value(decode_status([1, 0, 0, 0])).unwrap();
    assert_eq!(json["status"], serde_json::json!([1, 0, 0, 0]));
    assert_eq!(json["flags"], serde_json::json!(["RUNNING_FORWARD"]));
}

#[test]
fn reply_encoder_round_trips() {
    let row = table::command("read_speed_error").unwrap();
    let data = table::encode_reply(row, 2, 2, &[("motor_speed", 1500), ("rpm_error", -30)]).unwrap();
    assert_eq!(hex(&data), "26 02 02 DC 05 E2 FF 00");
    let get = table::command("get_digital_outputs").unwrap();
    assert_eq!(hex(&table::encode_reply(get, 0, 0x80, &[("state", 9)]).unwrap()), "11 00 00 09 00 00 00 00");
    let goto = table::command("goto").unwrap();
    assert_eq!(hex(&table::encode_reply(goto, 1, 0, &[]).unwrap()), "23 01 00 00 00 00 00 00");
}

#[test]
fn table_is_consistent() {
    let mut keys = BTreeSet::new();
    for c in COMMANDS {
        assert!(keys.insert(c.key), "duplicate key {}", c.key);
        assert!(!c.selectors.is_empty(), "{}", c.key);
        for other in COMMANDS.iter().filter(|o| o.code == c.code && o.key != c.key) {
            for s in c.selectors {
                for v in s.lo..=s.hi {
                    assert!(other.selector(v).is_none(), "{} and {} share selector {v:#x}", c.key, other.key);
                }
            }
        }
        for fields in [c.fields, c.reply.fields] {
            let mut used = [0u8; 8];
            for f in fields {
                let (lo, hi) = f.kind.raw_range();
                assert!(f.min >= lo && f.max <= hi && f.min <= f.max, "{}.{}", c.key, f.key);
                if let Some(d) = f.default {
                    assert!(f.in_range(d), "{}.{} default", c.key, f.key);
                }
                assert!(f.offset >= 3 && f.offset as usize + f.kind.width() <= 8, "{}.{}", c.key, f.key);
                let bits = match f.kind {
                    Kind::Bits { shift, width } => (((1u16 << width) - 1) << shift) as u8,
                    _ => 0xFF,
                };
                for i in 0..f.kind.width() {
                    let slot = &mut used[f.offset as usize + i];
                    assert_eq!(*slot & bits, 0, "{}.{} overlaps", c.key, f.key);
                    *slot |= bits;
                }
            }
        }
    }
    let mut seen = BTreeSet::new();
    for f in table::STATUS_FLAGS {
        assert!(seen.insert((f.byte, f.bit)) && (1..=4).contains(&f.byte) && f.bit < 8, "{}", f.name);
    }
    assert_eq!(table::STATUS_FLAGS.iter().map(|f| f.name).collect::<BTreeSet<_>>().len(), seen.len());
    for e in table::ERROR_BITS {
        let mut seen = BTreeSet::new();
        for f in e.bits {
            assert!(seen.insert((f.byte, f.bit)) && (1..=2).contains(&f.byte), "{:#x} {}", e.code, f.name);
        }
        assert!(COMMANDS.iter().any(|c| c.code == e.code));
    }
    assert_eq!(ServoPart::all().len(), 21);
    for p in ServoPart::all() {
        assert_eq!(ServoPart::from_selector(p.selector()), Some(p));
    }
}

fn arb_servo() -> impl Strategy<Value = ServoConfig> {
    let traject = prop::sample::select(Traject::ALL);
    let step = prop::sample::select(Step::ALL);
    prop_oneof![
        (1..=2500u16, 50..=32000u16, 1..=255u8).prop_map(|(a, b, c)| ServoConfig::Speeds {
            minimum_speed: a,
            maximum_speed: b,
            slope: c
        }),
        (1000..=10000u16, any::<bool>(), any::<bool>()).prop_map(|(a, b, c)| ServoConfig::Voltage {
            maximum_voltage: a,
            forward_end_switch: b,
            reverse_end_switch: c
        }),
        (1..=10000u16, any::<bool>(), any::<bool>(), any::<bool>()).prop_map(|(a, b, c, d)| ServoConfig::Encoder {
            pulses_per_revolution: a,
            hold_on_enable: b,
            auto_zero: c,
            sin2_slope: d
        }),
        (0..=10000u16, 1..=255u8, any::<u8>(), 0..=63u8).prop_map(|(a, b, c, d)| ServoConfig::Control {
            positioning_error: a,
            gain_factor: b,
            d_factor: c,
            failsafe: d
        }),
        (any::<bool>(), any::<bool>()).prop_map(|(a, b)| ServoConfig::Inputs { ready_input: a, error_input: b }),
        (traject.clone(), any::<i32>(), 0..=4u8).prop_map(|(t, p, l)| ServoConfig::TrajectEnd {
            traject: t,
            end_position: p,
            length: l
        }),
        (traject.clone(), 0..=32767u16).prop_map(|(t, s)| ServoConfig::TrajectInitialSpeed { traject: t, speed: s }),
        (traject.clone(), step.clone(), any::<i32>()).prop_map(|(t, s, p)| ServoConfig::TrajectChangePosition {
            traject: t,
            step: s,
            position: p
        }),
        (traject, step, 0..=32767u16).prop_map(|(t, s, v)| ServoConfig::TrajectSpeed { traject: t, step: s, speed: v }),
    ]
}

fn arb_command() -> impl Strategy<Value = Command> {
    let timers = (0..=7u8, any::<bool>(), 0..=7u8, any::<bool>()).prop_map(|(a, b, c, d)| Timers {
        position_interval: a,
        position_on_change: b,
        speed_interval: c,
        speed_on_change: d,
    });
    prop_oneof![
        any::<bool>().prop_map(|d| Command::StoreConfiguration { defaults: d }),
        (any::<bool>(), 0..=15u8).prop_map(|(l, o)| Command::SetDigitalOutputs { latched: l, outputs: o }),
        Just(Command::GetDigitalOutputs),
        (prop::sample::select(AnalogOutput::ALL), any::<bool>(), -10000..=10000i16)
            .prop_map(|(o, l, v)| Command::SetAnalogOutput { output: o, latched: l, millivolts: v }),
        prop::sample::select(AnalogOutput::ALL).prop_map(|o| Command::ReadAnalogOutput { output: o }),
        arb_servo().prop_map(Command::SetServoConfig),
        prop::sample::select(ServoPart::all()).prop_map(Command::ReadServoConfig),
        prop::sample::select(PositionSource::ALL).prop_map(Command::ReadPosition),
        any::<i32>().prop_map(|p| Command::SetPosition { position: p }),
        (prop::sample::select(GotoMode::ALL), any::<i32>()).prop_map(|(m, p)| Command::Goto { mode: m, position: p }),
        (prop::sample::select(Traject::ALL), any::<bool>())
            .prop_map(|(t, s)| Command::GotoTraject { traject: t, sync: s }),
        (0..=32767u16).prop_map(|s| Command::SetNextGotoSpeed { speed: s }),
        any::<i32>().prop_map(|p| Command::SetSpeedChangePosition { position: p }),
        (0..=32767u16).prop_map(|s| Command::ChangeGotoSpeed { speed: s }),
        (any::<bool>(), prop::sample::select(Direction::ALL), prop::sample::select(StartOption::ALL), 0..=30000u16)
            .prop_map(|(s, d, o, v)| Command::Start { sync: s, direction: d, option: o, motor_speed: v }),
        (any::<bool>(), prop::sample::select(StopOption::ALL)).prop_map(|(s, o)| Command::Stop { sync: s, option: o }),
        prop::sample::select(StatusSelector::ALL).prop_map(Command::ReadStatus),
        (any::<[u8; 4]>(), timers).prop_map(|(m, t)| Command::SetEventMask { masks: m, timers: t }),
        Just(Command::ReadEventMask),
        (0..=24u8).prop_map(|s| Command::Identify { selector: s }),
    ]
}

proptest! {
    #[test]
    fn command_round_trip(cmd in arb_command(), module in 0..=15u8) {
        let addr = if matches!(cmd, Command::Identify { .. }) { Address::Controller } else { m(module) };
        let data = cmd.encode(addr).unwrap();
        prop_assert_eq!(Command::decode(&data), Ok((addr, cmd)));
        let f = cmd.frame(NodeId::new(1 + module).unwrap(), addr).unwrap();
        prop_assert_eq!(f.id(), 0x201 + u32::from(module));
        prop_assert_eq!(f.data(), &data[..]);
        prop_assert_eq!(serde_json::to_value(cmd).is_ok(), true);
    }

    #[test]
    fn decoders_never_panic(id in 0u32..0x800, ext in any::<bool>(), data in prop::collection::vec(any::<u8>(), 0..=8)) {
        let f = if ext { CanFrame::new_extended(id, &data) } else { CanFrame::new(id, &data) }.unwrap();
        let _ = transport::classify(&f);
        if let Ok(Some(a)) = Answer::from_frame(&f) {
            let _ = a.reply();
            if let Some(e) = a.error() {
                let _ = (e.flags(), e.unknown_bits(), e.describe());
            }
        }
        let _ = ErrorReply::decode(&data);
        let _ = table::decode_reply(&data);
        let _ = Command::decode(&data);
        if let Ok(d) = table::decode_command(&data) {
            let _ = d.validate();
        }
        if let Ok(r) = table::decode_reply(&data) {
            let _ = ServoConfig::from_reply(&r);
            let _ = serde_json::to_string(&r);
        }
        let mut s = [0u8; 4];
        for (slot, b) in s.iter_mut().zip(&data) { *slot = *b; }
        let _ = decode_status(s);
    }

    #[test]
    fn error_reply_round_trip(cmd in 0u8..0x80, module: u8, general: u8, s1: u8, s2: u8) {
        let e = ErrorReply::new(cmd, module, general, s1, s2);
        prop_assert_eq!(ErrorReply::decode(&e.to_data()), Ok(e));
        let a = Answer::from_data(node1(), &e.to_data()).unwrap();
        prop_assert_eq!(a.kind, AnswerKind::Error);
        prop_assert_eq!(a.error(), Some(e));
    }

    #[test]
    fn reply_round_trip(idx in 0..COMMANDS.len(), module in 0..=15u8, seed: [i64; 8]) {
        let row = &COMMANDS[idx];
        let sel = row.selectors[0].lo;
        let values: Vec<(&str, i64)> = row.reply.fields.iter().zip(seed)
            .map(|(f, s)| (f.key, f.min + s.rem_euclid(f.max - f.min + 1)))
            .collect();
        let data = table::encode_reply(row, module, sel, &values).unwrap();
        let r = table::decode_reply(&data).unwrap();
        prop_assert_eq!(r.def.map(|d| d.reply.fields), Some(row.reply.fields));
        for (k, v) in values {
            prop_assert_eq!(r.get(k), Some(v));
        }
    }
}

#[test]
fn class_names_are_the_serde_names() {
    for c in [table::Class::Error, table::Class::Info] {
        assert_eq!(serde_json::to_value(c).unwrap(), c.name());
    }
}
