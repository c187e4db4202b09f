// Fault injection for kestrel-devices (LD_PRELOAD): libusb_init fails as it does where libusb
// finds no usable USB device nodes (a container without /dev/bus/usb on a non-udev build). The
// real libusb on this machine starts anyway, so this is the only way to run that branch here.
#include <libusb.h>

extern "C" int libusb_init(libusb_context** context) {
  if (context != nullptr) *context = nullptr;
  return LIBUSB_ERROR_OTHER;
}
