//! `axisctl decode` of what issue 15 found still shown raw: the Profibus
//! image's answer bytes and the PA-CONTROL CMD reply in both written forms.

use crate::common;

use common::run;

#[test]
fn profibus_image_answer_is_decoded_not_a_debug_string() {
    let r = run(&["--json", "decode", "profibus-image", "0a3c0000403f00000010270000040012"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    assert_eq!(r.json()["answer_decoded"], "ActPos = 0.75");
    assert_eq!(r.json()["answer_details"]["param"], "ActPos");
    let text = run(&["decode", "profibus-image", "0a 27 02 00 00 00 00 00 00 10 27 00 00 04 00 12"]);
    assert_eq!(text.code, 0, "{}", text.stderr);
    assert!(
        text.stdout.contains("answer      0a 27 02 00 00 00 00 00  CubeState = 2 [STATE_HOME_OK]"),
        "{}",
        text.stdout
    );
    assert!(!text.stdout.contains("Get {") && !text.stdout.contains("[0a,"), "{}", text.stdout);
    let bad = run(&["--json", "decode", "profibus-image", "ff3c0000403f00000010270000040012"]);
    assert_eq!(bad.code, 0);
    assert!(bad.json()["answer_decoded"].is_null());
    assert_eq!(bad.json()["answer_error"], "unknown command id 0xff");
}

#[test]
fn pac_cmd_reply_takes_8_hex_bytes_and_the_0x_number_alike() {
    let forms = ["00 00 00 01 00 01 A0 00", "00:00:00:01:00:01:a0:00", "000000010001A000", "0x000000010001A000"];
    let outs: Vec<_> = forms.iter().map(|f| run(&["--json", "decode", "pac-cmd-reply", f])).collect();
    for (f, r) in forms.iter().zip(&outs) {
        assert_eq!(r.code, 0, "{f}: {}", r.stderr);
        assert_eq!(r.json(), outs[0].json(), "{f}");
    }
    assert_eq!(run(&["decode", "pac-cmd-reply", "00 00 00 01 00 01 A0"]).code, 2, "7 bytes");
}

// PA-CONTROL words decode into the common state shape, bits as integer masks.
#[test]
fn pac_words_decode_into_the_state_shape() {
    let r = run(&["--json", "decode", "pac-ctrl-status", "0x8001"]);
    assert_eq!(r.code, 0, "{}", r.stderr);
    let d = r.json();
    assert_eq!(d["raw"], 0x8001);
    assert_eq!(d["flags"], serde_json::json!(["integer_positions", "control_ready"]), "{d}");
    assert_eq!(
        (&d["details"][0]["mask"], &d["details"][1]["mask"]),
        (&serde_json::json!(0x8000), &serde_json::json!(1))
    );
    assert_eq!(d["unknown_bits"], 0, "{d}");
    let reserved = run(&["--json", "decode", "pac-ctrl-status", "0x1000"]).json();
    assert_eq!(
        (&reserved["unknown_bits"], &reserved["flags"]),
        (&serde_json::json!(0x1000), &serde_json::json!([])),
        "bit 12 is not in the table: {reserved}"
    );
    let fields = d["fields"].as_array().unwrap();
    assert!(fields.iter().all(|f| f["mask"].is_u64()), "{d}");
}
