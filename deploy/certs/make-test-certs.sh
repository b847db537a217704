#!/usr/bin/env bash
# Make a throw-away PKI for trying TLS/mTLS deployments of cortex-wm.
#
#   make-test-certs.sh OUTDIR [--router-name NAME] [--san ADDR]... [AGENT]...
#
# Creates in OUTDIR (re-using OUTDIR/ca.pem + ca.key when they already exist):
#   ca.pem, ca.key            test root CA
#   NAME.pem, NAME.key        router certificate, CN=NAME (default "router"),
#                             SAN = 127.0.0.1, localhost and every --san ADDR,
#                             usable as TLS server *and* client (router-to-router links)
#   AGENT.pem, AGENT.key      one client certificate per AGENT, CN=AGENT
#
# Run it again on the same OUTDIR to add another router (one per host) or more
# agents under the same CA. Keys are unencrypted: test use only, never commit them.
set -euo pipefail

usage() { sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'; exit "${1:-0}"; }

[[ $# -ge 1 ]] || usage 2
case "$1" in -h|--help) usage 0 ;; esac
OUT=$1; shift
ROUTER=router
SANS=()
AGENTS=()
while [[ $# -gt 0 ]]; do
  case "$1" in
    --router-name) ROUTER=${2:?--router-name needs a value}; shift 2 ;;
    --san) SANS+=("${2:?--san needs a value}"); shift 2 ;;
    -h|--help) usage 0 ;;
    -*) echo "unknown option: $1" >&2; usage 2 ;;
    *) AGENTS+=("$1"); shift ;;
  esac
done

valid_name() { [[ "$1" =~ ^[A-Za-z0-9][A-Za-z0-9._-]*$ ]]; }
valid_name "$ROUTER" || { echo "bad router name: $ROUTER" >&2; exit 2; }
for a in "${AGENTS[@]+"${AGENTS[@]}"}"; do
  valid_name "$a" || { echo "bad agent name: $a" >&2; exit 2; }
  [[ "$a" != ca ]] || { echo "agent name 'ca' is reserved" >&2; exit 2; }
done

command -v openssl >/dev/null || { echo "openssl not found" >&2; exit 1; }
mkdir -p "$OUT"
umask 077
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
DAYS=825

newkey() { openssl genpkey -algorithm EC -pkeyopt ec_paramgen_curve:P-256 -out "$1" 2>/dev/null; }

if [[ ! -f "$OUT/ca.pem" || ! -f "$OUT/ca.key" ]]; then
  newkey "$OUT/ca.key"
  openssl req -new -x509 -key "$OUT/ca.key" -out "$OUT/ca.pem" -days "$DAYS" \
    -subj "/CN=cortex-wm test CA $(date +%s)-$RANDOM" \
    -addext "basicConstraints=critical,CA:TRUE" \
    -addext "keyUsage=critical,keyCertSign,cRLSign" 2>/dev/null
fi

# issue NAME CN EXTFILE
issue() {
  local name=$1 cn=$2 ext=$3
  newkey "$OUT/$name.key"
  openssl req -new -key "$OUT/$name.key" -out "$TMP/$name.csr" -subj "/CN=$cn" 2>/dev/null
  openssl x509 -req -in "$TMP/$name.csr" -CA "$OUT/ca.pem" -CAkey "$OUT/ca.key" \
    -set_serial "0x$(openssl rand -hex 16)" -days "$DAYS" -extfile "$ext" \
    -out "$OUT/$name.pem" 2>/dev/null
}

san="IP:127.0.0.1,DNS:localhost"
for s in "${SANS[@]+"${SANS[@]}"}"; do
  if [[ "$s" =~ ^[0-9.]+$ || "$s" == *:* ]]; then san+=",IP:$s"; else san+=",DNS:$s"; fi
done
cat >"$TMP/router.ext" <<EXT
basicConstraints = critical, CA:FALSE
keyUsage = critical, digitalSignature, keyEncipherment
extendedKeyUsage = serverAuth, clientAuth
subjectAltName = $san
EXT
issue "$ROUTER" "$ROUTER" "$TMP/router.ext"

cat >"$TMP/client.ext" <<EXT
basicConstraints = critical, CA:FALSE
keyUsage = critical, digitalSignature, keyEncipherment
extendedKeyUsage = clientAuth
EXT
for a in "${AGENTS[@]+"${AGENTS[@]}"}"; do
  issue "$a" "$a" "$TMP/client.ext"
done

chmod 600 "$OUT"/*.key
chmod 644 "$OUT"/*.pem
echo "certificates in $OUT: router=$ROUTER (SAN $san) agents=${AGENTS[*]-}"
