//! The latency timer against a fake sysfs tree (a tempdir), and on a pty.

use std::path::PathBuf;

use super::*;
use crate::line::transport::pty_pair;

/// A fake sysfs root with `ttyUSB0` behind ftdi_sio (timer `ms`), `ttyS0` behind serial8250
/// and `ttyUSB1` as the usb-serial bus lays it out only.
struct FakeSys(PathBuf);

impl FakeSys {
    fn new(tag: &str, ms: &str) -> Self {
        let root = std::env::temp_dir().join(format!("softplc-sysfs-{tag}-{}", std::process::id()));
        // A leftover of an earlier run, if any; usually there is none.
        drop(std::fs::remove_dir_all(&root));
        let usb = root.join("devices/pci0000:00/usb1/1-1/1-1:1.0/ttyUSB0");
        std::fs::create_dir_all(usb.join("tty/ttyUSB0")).unwrap();
        std::fs::write(usb.join("latency_timer"), ms).unwrap();
        std::fs::create_dir_all(root.join("class/tty")).unwrap();
        // As the kernel lays it out: the class entry links to the tty, whose `device` is the
        // usb-serial port that holds the attribute.
        std::os::unix::fs::symlink(usb.join("tty/ttyUSB0"), root.join("class/tty/ttyUSB0"))
            .unwrap();
        std::os::unix::fs::symlink(&usb, usb.join("tty/ttyUSB0/device")).unwrap();
        let uart = root.join("devices/platform/serial8250/tty/ttyS0");
        std::fs::create_dir_all(&uart).unwrap();
        std::fs::create_dir_all(root.join("bus/platform/drivers/serial8250")).unwrap();
        std::fs::create_dir_all(root.join("devices/platform/serial8250/port")).unwrap();
        std::os::unix::fs::symlink(
            root.join("devices/platform/serial8250/port"),
            uart.join("device"),
        )
        .unwrap();
        std::os::unix::fs::symlink(
            root.join("bus/platform/drivers/serial8250"),
            root.join("devices/platform/serial8250/port/driver"),
        )
        .unwrap();
        std::os::unix::fs::symlink(&uart, root.join("class/tty/ttyS0")).unwrap();
        let bus = root.join("bus/usb-serial/devices/ttyUSB1");
        std::fs::create_dir_all(&bus).unwrap();
        std::fs::write(bus.join("latency_timer"), "16\n").unwrap();
        Self(root)
    }

    fn root(&self) -> SysfsRoot {
        SysfsRoot(self.0.clone())
    }
}

impl Drop for FakeSys {
    fn drop(&mut self) {
        // Best effort: the test's scratch folder.
        drop(std::fs::remove_dir_all(&self.0));
    }
}

fn named(n: &str) -> TtyNode {
    TtyNode::Named(n.into())
}

#[test]
fn reads_the_ftdi_timer_through_the_class_link_and_the_usb_serial_bus() {
    let sys = FakeSys::new("read", "16\n");
    let root = sys.root();
    assert_eq!(
        probe(&root, &named("ttyUSB0")),
        Probe::Timer {
            path: sys.0.join("class/tty/ttyUSB0/device/latency_timer"),
            ms: 16
        }
    );
    assert_eq!(
        probe(&root, &named("ttyUSB1")),
        Probe::Timer {
            path: sys.0.join("bus/usb-serial/devices/ttyUSB1/latency_timer"),
            ms: 16
        }
    );
    assert_eq!(
        probe(&root, &named("ttyS0")),
        Probe::None(NoTimer::Driver("serial8250".into()))
    );
    assert_eq!(probe(&root, &named("ttyUSB9")), Probe::Absent);
    // Linux 6.5 and later: the tty's device is serial-base's port, below its ctrl, below the
    // UART whose driver names it.
    let pl011 = sys.0.join("devices/platform/fe201000.serial");
    let port = pl011.join("fe201000.serial:0/fe201000.serial:0.0");
    std::fs::create_dir_all(port.join("tty/ttyAMA0")).unwrap();
    for (dir, driver) in [
        (port.clone(), "bus/serial-base/drivers/port"),
        (
            pl011.join("fe201000.serial:0"),
            "bus/serial-base/drivers/ctrl",
        ),
        (pl011.clone(), "bus/amba/drivers/uart-pl011"),
    ] {
        std::fs::create_dir_all(sys.0.join(driver)).unwrap();
        std::os::unix::fs::symlink(sys.0.join(driver), dir.join("driver")).unwrap();
    }
    std::os::unix::fs::symlink(&port, port.join("tty/ttyAMA0/device")).unwrap();
    std::os::unix::fs::symlink(port.join("tty/ttyAMA0"), sys.0.join("class/tty/ttyAMA0")).unwrap();
    assert_eq!(
        probe(&root, &named("ttyAMA0")),
        Probe::None(NoTimer::Driver("uart-pl011".into()))
    );
    assert_eq!(probe(&root, &TtyNode::Pty), Probe::None(NoTimer::Pty));
}

#[test]
fn what_check_assumes_says_where_it_came_from() {
    let sys = FakeSys::new("assume", "16\n");
    let root = sys.root();
    let auto = |port: &str| Assumed::for_port(AdapterLatency::Auto, Path::new(port), &root);
    let usb0 = auto("/dev/ttyUSB0");
    assert_eq!(usb0.latency, Duration::from_millis(16));
    assert_eq!(
        usb0.to_string(),
        format!(
            "16 ms, read from {}/class/tty/ttyUSB0/device/latency_timer",
            sys.0.display()
        )
    );
    assert_eq!(
        auto("/dev/ttyS0").to_string(),
        "none: its driver serial8250 has no latency timer"
    );
    assert_eq!(auto("/dev/ttyS0").latency, Duration::ZERO);
    assert_eq!(
        auto("/dev/ttyUSB9").to_string(),
        "0 ms assumed: /dev/ttyUSB9 is not on this machine (set adapter_latency to the \
         adapter's: 16 ms for an FTDI adapter without the udev rule, 1 ms with it); `run` \
         starts with this line lost and takes the port when it appears"
    );
    let fixed = Assumed::for_port(
        AdapterLatency::AtMost(Duration::from_millis(2)),
        Path::new("/dev/ttyUSB0"),
        &root,
    );
    assert_eq!(fixed.to_string(), "2 ms, configured");
    assert_eq!(Assumed::simulated().to_string(), "none: simulated line");

    let sys = FakeSys::new("garbled", "sixteen\n");
    let bad = Assumed::for_port(AdapterLatency::Auto, Path::new("/dev/ttyUSB0"), &sys.root());
    assert_eq!(bad.latency, Duration::ZERO);
    assert!(
        bad.to_string()
            .ends_with("device/latency_timer: invalid data"),
        "{bad}"
    );
}

#[test]
fn a_pty_has_no_latency_timer() {
    let (_master, _slave, name) = pty_pair().unwrap();
    assert_eq!(TtyNode::of(Path::new(&name)), TtyNode::Pty);
    let assumed = Assumed::for_port(
        AdapterLatency::Auto,
        Path::new(&name),
        &SysfsRoot::default(),
    );
    assert_eq!(assumed.latency, Duration::ZERO);
    assert_eq!(assumed.to_string(), "none: pty");
}

#[test]
fn a_pty_refuses_low_latency_by_name_of_the_ioctl() {
    let (_master, slave, _name) = pty_pair().unwrap();
    let e = set_low_latency(&slave).unwrap_err();
    assert_eq!(e.ioctl, "TIOCGSERIAL");
    assert_eq!(e.errno, libc::ENOTTY);
    assert_eq!(
        e.to_string(),
        "TIOCGSERIAL refused ASYNC_LOW_LATENCY: Inappropriate ioctl for device (os error 25)"
    );
}

#[test]
fn opening_lowers_a_16_ms_timer_to_1_through_sysfs_when_the_ioctl_is_refused() {
    // The port is a pty (it refuses TIOCGSERIAL), its sysfs node the fake FTDI one.
    let sys = FakeSys::new("lower", "16\n");
    let (_master, slave, _name) = pty_pair().unwrap();
    let lowered = lower(&sys.root(), &slave, &named("ttyUSB0"));
    assert_eq!(lowered.effective(), Duration::from_millis(1));
    assert!(!lowered.left_high());
    let attr = sys.0.join("class/tty/ttyUSB0/device/latency_timer");
    assert_eq!(std::fs::read_to_string(&attr).unwrap(), "1");
    assert_eq!(
        lowered.to_string(),
        format!(
            "latency timer 1 ms ({p}), was 16 ms; TIOCGSERIAL refused ASYNC_LOW_LATENCY: \
             Inappropriate ioctl for device (os error 25); 1 written to {p}",
            p = attr.display()
        )
    );
    // Already at 1 ms: nothing is tried.
    let again = lower(&sys.root(), &slave, &named("ttyUSB0"));
    assert_eq!((again.low_latency, again.written), (None, None));
    assert_eq!(
        again.to_string(),
        format!("latency timer 1 ms ({})", attr.display())
    );
}

#[test]
fn a_timer_left_above_a_demanded_ceiling_is_refused_with_what_was_tried() {
    let attr = PathBuf::from("/sys/class/tty/ttyUSB0/device/latency_timer");
    let lowered = Lowered {
        before: Probe::Timer {
            path: attr.clone(),
            ms: 16,
        },
        after: Some(16),
        low_latency: Some(Err(LowLatencyRefused {
            ioctl: "TIOCSSERIAL",
            errno: libc::EINVAL,
        })),
        written: Some(Err(libc::EACCES)),
    };
    assert!(lowered.left_high());
    let refused = LatencyRefused {
        port: PathBuf::from("/dev/ttyUSB0"),
        lowered,
        demanded: Duration::from_millis(2),
    };
    assert_eq!(
        refused.to_string(),
        "/dev/ttyUSB0: the adapter's latency timer 16 ms (/sys/class/tty/ttyUSB0/device/latency_timer); \
         TIOCSSERIAL refused ASYNC_LOW_LATENCY: Invalid argument (os error 22); writing 1 to it \
         was refused: Permission denied (os error 13) (the udev rule in deploy/ sets it at \
         plug-in), above adapter_latency 2 ms (run as root, install the udev rule, or raise \
         adapter_latency to what the adapter has)"
    );
}

#[test]
fn serial_struct_is_the_kernels_layout() {
    // x86_64 / aarch64: 72 bytes, flags at offset 16.
    #[cfg(target_pointer_width = "64")]
    assert_eq!(std::mem::size_of::<SerialStruct>(), 72);
    assert_eq!(std::mem::offset_of!(SerialStruct, flags), 16);
}

#[test]
fn a_demanded_ceiling_holds_only_when_the_port_gets_under_it() {
    let (_master, slave, _name) = pty_pair().unwrap();
    let port = Path::new("/dev/ttyUSB0");
    let ms = Duration::from_millis;
    // The fake FTDI timer goes from 16 to 1 ms (through sysfs: the pty refuses the ioctl).
    let opened = |config| {
        let sys = FakeSys::new("enforce", "16\n");
        enforce(config, lower(&sys.root(), &slave, &named("ttyUSB0")), port)
    };
    assert_eq!(opened(AdapterLatency::Auto), Ok(ms(1)));
    assert_eq!(opened(AdapterLatency::AtMost(ms(1))), Ok(ms(1)));
    let refused = opened(AdapterLatency::AtMost(ms(0))).unwrap_err();
    assert_eq!(refused.demanded, ms(0));
    assert!(
        refused
            .to_string()
            .starts_with("/dev/ttyUSB0: the adapter's latency timer 1 ms ("),
        "{refused}"
    );
    assert!(
        refused.to_string().ends_with(
            ", above adapter_latency 0 ms (run as root, install \
         the udev rule, or raise adapter_latency to what the adapter has)"
        ),
        "{refused}"
    );
    // Without a timer (a pty, a UART) any ceiling holds: it adds nothing.
    let none = lower(&SysfsRoot::default(), &slave, &TtyNode::Pty);
    assert_eq!(
        enforce(AdapterLatency::AtMost(ms(0)), none, port),
        Ok(ms(0))
    );
}
