//! VDA 5050 over MQTT (issue 18, part 4): the real `slam-service` with `--mqtt-url`
//! publishes each session's `visualization` and `connection` to a real MQTT broker
//! (`mqtt-broker`, rumqttd in a process of its own) while the simulator feeds it.
//!
//! Every message a subscriber receives is validated against the official VDA 5050 2.1
//! JSON schemas (`tests/data/vda5050/`, from VDA5050/VDA5050, MIT), formats included; the
//! `headerId` of each topic increases; `visualization` stays under its configured rate.
//! The broker is killed mid-session: HTTP and mapping go on, and when it is back the
//! service reconnects (ONLINE again) and visualization resumes. A stopped session says
//! OFFLINE; a killed service's session says CONNECTIONBROKEN, through its last will.

mod common;

use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime};

use anyhow::{Context, Result, bail, ensure};
use common::{SERVICE_LOG, in_temp_dir, paper_env1_sketch_a, start_service, wait_session};
use rumqttc::{AsyncClient, Event, MqttOptions, Packet, QoS};
use serde_json::Value;
use sketchslam_api::MappingMethod;
use sketchslam_tests::processes::{
    ChildGuard, binary, bundled_scenario, free_port, unique_prefix, workspace_root,
};
use sketchslam_tests::session_request::{baseline_session, sketch_session};

/// The rate the service is asked for, Hz.
const RATE_HZ: f64 = 5.0;

/// One message as the subscriber got it.
#[derive(Debug, Clone)]
struct Received {
    topic: String,
    payload: Vec<u8>,
    /// Set by the broker only on a retained message replayed at subscription.
    retain: bool,
}

type Inbox = Arc<Mutex<Vec<Received>>>;

fn start_broker(port: u16, log: &Path) -> Result<ChildGuard> {
    let exe = binary("sketchslam-tests", "mqtt-broker")?;
    let log = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(log)?;
    let mut cmd = Command::new(exe);
    cmd.args(["--port", &port.to_string()])
        .stdout(Stdio::null())
        .stderr(log);
    let broker = ChildGuard::spawn("mqtt-broker", &mut cmd)?;
    let deadline = Instant::now() + Duration::from_secs(20);
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        ensure!(
            Instant::now() < deadline,
            "the broker did not listen on {port}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    Ok(broker)
}

/// Subscribes to every robot's VDA 5050 topics (again at each reconnection: a broker
/// that restarted has forgotten the subscription) and keeps what arrives.
fn subscribe(port: u16) -> Inbox {
    let inbox: Inbox = Arc::default();
    let kept = inbox.clone();
    let mut options = MqttOptions::new(unique_prefix("vda-listener"), "127.0.0.1", port);
    options.set_keep_alive(Duration::from_secs(5));
    let (client, mut events) = AsyncClient::new(options, 64);
    tokio::spawn(async move {
        loop {
            match events.poll().await {
                Ok(Event::Incoming(Packet::ConnAck(_))) => {
                    let _ = client.try_subscribe("uagv/v2/sketchslam/+/+", QoS::AtLeastOnce);
                }
                Ok(Event::Incoming(Packet::Publish(p))) => {
                    kept.lock()
                        .unwrap_or_else(|e| e.into_inner())
                        .push(Received {
                            topic: p.topic.clone(),
                            payload: p.payload.to_vec(),
                            retain: p.retain,
                        });
                }
                Ok(_) => {}
                Err(_) => tokio::time::sleep(Duration::from_millis(200)).await,
            }
        }
    });
    inbox
}

fn snapshot(inbox: &Inbox) -> Vec<Received> {
    inbox.lock().unwrap_or_else(|e| e.into_inner()).clone()
}

/// Waits until `pred` holds for the messages received so far.
async fn wait_for(
    inbox: &Inbox,
    timeout: Duration,
    what: &str,
    pred: impl Fn(&[Received]) -> bool,
) -> Result<()> {
    let deadline = Instant::now() + timeout;
    loop {
        if pred(&snapshot(inbox)) {
            return Ok(());
        }
        if Instant::now() > deadline {
            let got: Vec<String> = snapshot(inbox)
                .iter()
                .rev()
                .take(5)
                .map(|r| format!("{} {}", r.topic, String::from_utf8_lossy(&r.payload)))
                .collect();
            bail!("timed out after {timeout:?} waiting for {what}; last messages: {got:#?}");
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

fn json(r: &Received) -> Value {
    serde_json::from_slice(&r.payload).unwrap_or(Value::Null)
}

fn is_state(r: &Received, robot: &str, state: &str) -> bool {
    r.topic == format!("uagv/v2/sketchslam/{robot}/connection")
        && json(r)["connectionState"] == state
}

fn visualizations<'a>(got: &'a [Received], robot: &str) -> Vec<&'a Received> {
    let topic = format!("uagv/v2/sketchslam/{robot}/visualization");
    got.iter().filter(|r| r.topic == topic).collect()
}

fn schema(name: &str) -> Result<jsonschema::Validator> {
    let path = workspace_root().join(format!("tests/data/vda5050/{name}.schema"));
    let schema: Value = serde_json::from_slice(&std::fs::read(&path)?)
        .with_context(|| format!("{}", path.display()))?;
    jsonschema::draft202012::options()
        .should_validate_formats(true)
        .build(&schema)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}

/// Every message against its schema and the header rules, each robot's positions on the
/// map `map_ids` names for it.
fn check_all(got: &[Received], map_ids: &BTreeMap<&str, String>) -> Result<()> {
    let visualization = schema("visualization")?;
    let connection = schema("connection")?;
    let mut last_id: BTreeMap<&str, u64> = BTreeMap::new();
    for r in got {
        let message: Value =
            serde_json::from_slice(&r.payload).with_context(|| format!("{}: not JSON", r.topic))?;
        let (validator, robot) = match r.topic.rsplit_once('/') {
            Some((rest, "visualization")) => (&visualization, rest.rsplit('/').next()),
            Some((rest, "connection")) => (&connection, rest.rsplit('/').next()),
            _ => bail!("unexpected topic {}", r.topic),
        };
        let robot = robot.unwrap_or_default();
        if let Err(e) = validator.validate(&message) {
            bail!("{} breaks the VDA 5050 2.1 schema: {e}\n{message}", r.topic);
        }
        ensure!(message["version"] == "2.1.0", "{message}");
        ensure!(message["manufacturer"] == "sketchslam", "{message}");
        ensure!(message["serialNumber"] == robot, "{message}");
        let stamp = message["timestamp"].as_str().unwrap_or_default();
        ensure!(
            stamp.ends_with('Z') && humantime::parse_rfc3339(stamp).is_ok(),
            "timestamp {stamp:?} is not ISO 8601 UTC"
        );
        if r.topic.ends_with("/visualization") {
            let position = &message["agvPosition"];
            ensure!(position["positionInitialized"] == true, "{message}");
            ensure!(
                position["mapId"].as_str() == map_ids.get(robot).map(String::as_str),
                "mapId is not {:?}: {message}",
                map_ids.get(robot)
            );
            ensure!(
                position["deviationRange"].as_f64().is_some_and(|d| d > 0.0),
                "{message}"
            );
            let theta = position["theta"].as_f64().unwrap_or(f64::NAN);
            ensure!(theta.abs() <= std::f64::consts::PI, "{message}");
        }
        // A retained message replayed at subscription repeats an older one.
        if r.retain {
            continue;
        }
        let id = message["headerId"].as_u64().context("headerId")?;
        if let Some(previous) = last_id.insert(r.topic.as_str(), id) {
            ensure!(id > previous, "{}: headerId {id} after {previous}", r.topic);
        }
    }
    Ok(())
}

/// The simulator publishing `max_scans` of paper-env1 in real time as `robot` on `prefix`.
fn simulate_paper_env1(robot: &str, prefix: &str, max_scans: u64) -> Result<ChildGuard> {
    let mut cmd = Command::new(binary("sketchslam-simulator", "simulator")?);
    cmd.arg("run")
        .arg(bundled_scenario("paper-env1"))
        .args(["--robot", robot, "--rate", "1.0", "--quiet"])
        .args(["--ipc-prefix", prefix])
        .args(["--max-scans", &max_scans.to_string()])
        .stdout(Stdio::null())
        .stderr(Stdio::null());
    ChildGuard::spawn("simulator", &mut cmd)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn vda5050_messages_follow_the_schemas_and_outlive_a_broker_restart() -> Result<()> {
    in_temp_dir(
        "vda5050",
        &[(SERVICE_LOG, 60), ("broker.log", 20)],
        |dir| async move { run(&dir, &dir.join("data")).await },
    )
    .await
}

async fn run(dir: &Path, data: &Path) -> Result<()> {
    let port = free_port()?;
    let broker_log = dir.join("broker.log");
    let mut broker = start_broker(port, &broker_log)?;
    let inbox = subscribe(port);
    let prefix = unique_prefix("vda5050");
    let url = format!("mqtt://127.0.0.1:{port}");
    let rate = RATE_HZ.to_string();
    let mut service = start_service(
        data,
        &prefix,
        &["--mqtt-url", &url, "--vda5050-rate-hz", &rate],
        &[],
    )
    .await?;
    let client = service.client.clone();

    // A graph session for robot vda-1, fed by the simulator in real time, and one for
    // vda-2, whose robot never comes: it is connected all the same.
    let (robot, robot2) = ("vda-1", "vda-2");
    let mut sessions = BTreeMap::new();
    for r in [robot, robot2] {
        let s = client
            .create_session(&baseline_session(r, MappingMethod::Graph, None))
            .await?;
        sessions.insert(r, s.id);
    }
    let session = sessions[robot].clone();
    // Robot vda-3 maps on sketch A, uploaded with its scale: its positions are on the
    // drawing (mapId the drawing's id), where the sketch session puts it.
    let drawn = "vda-3";
    let (_, sketch_cfg) = paper_env1_sketch_a()?;
    let drawing = client
        .upload_sketch_with_scale(
            std::fs::read(&sketch_cfg.image)?,
            Some("A"),
            Some(sketch_cfg.meters_per_pixel),
        )
        .await?;
    let mut on_drawing = sketch_session(drawn, &drawing.id, &sketch_cfg, None);
    on_drawing.meters_per_pixel = None;
    let drawn_session = client.create_session(&on_drawing).await?;
    ensure!(
        drawn_session.meters_per_pixel_guess == Some(sketch_cfg.meters_per_pixel),
        "the session did not take the drawing's scale: {drawn_session:?}"
    );
    let mut map_ids = sessions.clone();
    map_ids.insert(drawn, drawing.id.clone());
    let _drawn_sim = simulate_paper_env1(drawn, &prefix, 200)?;
    let _sim = simulate_paper_env1(robot, &prefix, 1200)?;

    let online_of_both = |got: &[Received]| {
        got.iter().any(|r| is_state(r, robot, "ONLINE"))
            && got.iter().any(|r| is_state(r, robot2, "ONLINE"))
    };
    wait_for(
        &inbox,
        Duration::from_secs(30),
        "ONLINE of both",
        online_of_both,
    )
    .await?;
    wait_for(
        &inbox,
        Duration::from_secs(60),
        "10 visualizations",
        |got| visualizations(got, robot).len() >= 10 && visualizations(got, drawn).len() >= 5,
    )
    .await?;
    // In the drawing's frame: x = u·s, y = (H − v)·s. The first position is at the start
    // marked on the drawing (within the 1 m the robot can have moved), every one on it.
    let s = sketch_cfg.meters_per_pixel;
    let (w_m, h_m) = (
        f64::from(drawing.width_px) * s,
        f64::from(drawing.height_px) * s,
    );
    let start = (
        sketch_cfg.start_u_px * s,
        (f64::from(drawing.height_px) - sketch_cfg.start_v_px) * s,
    );
    let placed: Vec<(f64, f64)> = visualizations(&snapshot(&inbox), drawn)
        .iter()
        .map(|r| {
            let p = &json(r)["agvPosition"];
            (
                p["x"].as_f64().unwrap_or(f64::NAN),
                p["y"].as_f64().unwrap_or(f64::NAN),
            )
        })
        .collect();
    let first = placed[0];
    ensure!(
        (first.0 - start.0).hypot(first.1 - start.1) < 1.0,
        "vda-3's first position {first:?} is not at the start marked on the drawing {start:?}"
    );
    ensure!(
        placed
            .iter()
            .all(|&(x, y)| (0.0..=w_m).contains(&x) && (0.0..=h_m).contains(&y)),
        "vda-3 placed off the {w_m} × {h_m} m drawing: {placed:?}"
    );

    // The broker goes away: HTTP answers and the session goes on mapping.
    broker.kill();
    let before = client.get_session(&session).await?.scans_processed;
    wait_session(
        &client,
        &session,
        Duration::from_secs(30),
        "mapping while the broker is away",
        |i| i.scans_processed >= before + 20,
    )
    .await?;

    // It comes back on the same port: the service reconnects by itself, and sends only
    // what it stamps from then on (nothing kept from while the broker was away).
    let away_from = snapshot(&inbox).len();
    let back_at = SystemTime::now();
    let mut broker = start_broker(port, &broker_log)?;
    wait_for(
        &inbox,
        Duration::from_secs(30),
        "both ONLINE again",
        |got| online_of_both(&got[away_from..]),
    )
    .await?;
    wait_for(
        &inbox,
        Duration::from_secs(30),
        "visualization again",
        |got| visualizations(&got[away_from..], robot).len() >= 5,
    )
    .await?;
    for r in visualizations(&snapshot(&inbox)[away_from..], robot) {
        let stamp = json(r)["timestamp"]
            .as_str()
            .unwrap_or_default()
            .to_string();
        let at = humantime::parse_rfc3339(&stamp).with_context(|| stamp.clone())?;
        ensure!(
            at >= back_at,
            "a visualization stamped {stamp} arrived after the broker came back: kept from while it was away"
        );
    }

    // An orderly stop says OFFLINE, and nothing after it.
    client.stop_session(&session).await?;
    wait_for(&inbox, Duration::from_secs(30), "OFFLINE of vda-1", |got| {
        got.iter().any(|r| is_state(r, robot, "OFFLINE"))
    })
    .await?;

    // A killed service's session says CONNECTIONBROKEN: the broker sends its will, whose
    // headerId must follow vda-2's two ONLINEs (checked with the others below).
    service.guard.kill();
    wait_for(
        &inbox,
        Duration::from_secs(30),
        "CONNECTIONBROKEN of vda-2",
        |got| got.iter().any(|r| is_state(r, robot2, "CONNECTIONBROKEN")),
    )
    .await?;
    broker.kill();

    let got = snapshot(&inbox);
    check_all(&got, &map_ids)?;
    let last_state = |r: &str| {
        got.iter()
            .rev()
            .find(|m| m.topic == format!("uagv/v2/sketchslam/{r}/connection"))
            .map(|m| json(m)["connectionState"].clone())
    };
    ensure!(
        last_state(robot) == Some("OFFLINE".into()),
        "vda-1 ended {:?}",
        last_state(robot)
    );
    ensure!(
        last_state(robot2) == Some("CONNECTIONBROKEN".into()),
        "vda-2 ended {:?}",
        last_state(robot2)
    );

    // The rate, from the messages' own stamps: a tick every 1/RATE_HZ at most, so no more
    // than span · RATE_HZ + 1 messages, whatever the delivery did to their arrival.
    let vis = visualizations(&got, robot);
    let stamps: Vec<SystemTime> = vis
        .iter()
        .filter_map(|r| humantime::parse_rfc3339(json(r)["timestamp"].as_str()?).ok())
        .collect();
    let span_s = match (stamps.first(), stamps.last()) {
        (Some(a), Some(b)) => b.duration_since(*a).unwrap_or_default().as_secs_f64(),
        _ => 0.0,
    };
    let sizes: Vec<usize> = vis.iter().map(|r| r.payload.len()).collect();
    let mean_size = sizes.iter().sum::<usize>() as f64 / sizes.len().max(1) as f64;
    println!(
        "visualization: {} messages over {span_s:.1} s, broker outage included (asked {RATE_HZ} Hz), \
         {mean_size:.0} bytes each (max {}); connection: {} messages",
        vis.len(),
        sizes.iter().max().unwrap_or(&0),
        got.iter()
            .filter(|r| r.topic.ends_with("/connection"))
            .count()
    );
    ensure!(
        vis.len() as f64 <= span_s * RATE_HZ * 1.02 + 1.0,
        "{} visualizations in {span_s:.1} s: faster than {RATE_HZ} Hz",
        vis.len()
    );
    Ok(())
}
