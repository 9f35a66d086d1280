"""Why libfreenect finds no Kinect, or cannot open it, told from the USB device list (ROS-free).

libfreenect says only "no devices" or "could not open"; the kernel's view says which: nothing of
Microsoft's on the bus (cable, power), the camera missing beside the motor and audio devices
(the 12 V supply), a device node the user may not write (the udev rule Debian's libfreenect0.5
installs gives group plugdev access), the kernel's gspca_kinect driver holding the camera, or a
model without the motor device.
"""

import grp
import os
import pwd

from openni_camera import kinect

SYSFS = "/sys/bus/usb/devices"
DEV_ROOT = "/dev/bus/usb"
UDEV_RULE = "/lib/udev/rules.d/60-libfreenect0.5.rules"


def _read(path):
    try:
        with open(path) as f:
            return f.read().strip()
    except OSError:
        return ""


def find_kinects(sysfs=SYSFS):
    """Microsoft Kinect USB devices: [{"product": int, "name", "bus", "device", "driver"}] (driver:
    the kernel driver bound to interface 0, or "")."""
    found = []
    try:
        entries = sorted(os.listdir(sysfs))
    except OSError:
        return None
    for entry in entries:
        base = os.path.join(sysfs, entry)
        if _read(os.path.join(base, "idVendor")).lower() != f"{kinect.VENDOR:04x}":
            continue
        try:
            product = int(_read(os.path.join(base, "idProduct")), 16)
            bus, device = int(_read(os.path.join(base, "busnum"))), int(_read(os.path.join(base, "devnum")))
        except ValueError:
            continue
        driver_link = os.path.join(sysfs, f"{entry}:1.0", "driver")
        driver = os.path.basename(os.readlink(driver_link)) if os.path.islink(driver_link) else ""
        found.append({"product": product, "name": kinect.PRODUCTS.get(product, f"045e:{product:04x}"), "bus": bus,
                      "device": device, "driver": driver})
    return found


def _who():
    try:
        user = pwd.getpwuid(os.geteuid()).pw_name
    except KeyError:
        user = str(os.geteuid())
    groups = []
    for gid in os.getgroups():
        try:
            groups.append(grp.getgrgid(gid).gr_name)
        except KeyError:
            groups.append(str(gid))
    return user, groups


def diagnose(subdevice, sysfs=SYSFS, dev_root=DEV_ROOT, access=os.access):  # noqa: PLR0911 - one return per cause
    """A sentence on why the Kinect's ``subdevice`` ("camera" or "motor") cannot be used, from the
    USB device list; "" when nothing there explains it."""
    devices = find_kinects(sysfs)
    if devices is None:
        return f"no USB device list at {sysfs} (no USB on this machine, or a container without it)"
    products = {d["product"] for d in devices}
    if not devices:
        return ("no Kinect on USB (lsusb shows no 045e:02ae camera, 045e:02b0 motor or 045e:02ad audio): check "
                "the USB cable and that the Kinect's own 12 V power supply is plugged in")
    wanted = ({kinect.PRODUCT_CAMERA, kinect.PRODUCT_K4W_CAMERA} if subdevice == "camera" else {kinect.PRODUCT_MOTOR})
    present = [d for d in devices if d["product"] in wanted]
    if not present:
        if subdevice == "motor":
            extra = (" (045e:02c2 is there: models 1473 and Kinect for Windows have no motor device)"
                     if kinect.PRODUCT_NO_MOTOR in products else "")
            return ("this Kinect has no motor device 045e:02b0" + extra + ": tilt, LED and accelerometer cannot be "
                    "reached through libfreenect's motor interface")
        return ("the Kinect's camera (045e:02ae) is not on USB although its "
                + ", ".join(sorted(d["name"] for d in devices)) + " are: the camera needs the 12 V power supply")
    for d in present:
        node = os.path.join(dev_root, f"{d['bus']:03d}", f"{d['device']:03d}")
        if not os.path.exists(node):
            return f"the {d['name']} is on bus {d['bus']} device {d['device']} but {node} does not exist"
        if not access(node, os.R_OK | os.W_OK):
            user, groups = _who()
            try:
                st = os.stat(node)
                owner = f"mode {oct(st.st_mode & 0o777)}, group {grp.getgrgid(st.st_gid).gr_name}"
            except (OSError, KeyError):
                owner = "mode unknown"
            return (f"no permission: {node} (the {d['name']}, {owner}) is not writable by user {user} (groups "
                    f"{', '.join(groups) or 'none'}). Debian's libfreenect0.5 installs {UDEV_RULE}, which gives "
                    "group plugdev access: add the user to plugdev (adduser USER plugdev), log in again and replug "
                    "the Kinect")
        if d["driver"] and d["driver"] != "usbfs":
            return (f"the kernel's {d['driver']} driver holds the {d['name']}: unload it (modprobe -r {d['driver']}) "
                    "or blacklist it")
    return ""
