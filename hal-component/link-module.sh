#!/bin/sh
# Links a LinuxCNC uspace realtime module the way /usr/share/linuxcnc/Makefile.modinc does:
# only the names listed in the objects' .rtapi_export section stay visible.
#   link-module.sh OUTPUT.so CC OBJECT...
set -eu
out=$1
cc=$2
shift 2
tmp=$out.tmp
ld -d -r -o "$tmp" "$@"
objcopy -j .rtapi_export -O binary "$tmp" "$out.sym"
{
  echo '{ global : '
  tr -s '\0' < "$out.sym" | xargs -r0 printf '%s;\n' | grep .
  echo 'local : * ; };'
} > "$out.ver"
"$cc" -shared -Bsymbolic -Wl,--version-script,"$out.ver" -o "$out" "$tmp" -lm
chmod -x "$out"
rm -f "$tmp" "$out.sym"
