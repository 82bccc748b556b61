#!/usr/bin/env bash
# make-pki.sh OUT_DIR N — a test PKI for DDS Security (see README.md in this folder).
#
#   OUT_DIR/identity_ca.pem          identity CA certificate (self-signed, EC P-256)
#   OUT_DIR/permissions_ca.pem       permissions CA certificate (signs governance and permissions)
#   OUT_DIR/governance.xml|.p7s      domain governance (source | S/MIME-signed by the permissions CA)
#   OUT_DIR/<name>/cert.pem key.pem  identity certificate (signed by the identity CA) and its private key
#   OUT_DIR/<name>/permissions.xml|.p7s   that participant's grant (source | signed)
#   OUT_DIR/private/                 the two CA keys (only this script needs them; keep them offline)
# <name> is agent-0 … agent-(N-1), orchestrator and fusion.
#
# Idempotent: existing CA keys/certificates and participant keys/certificates are kept; missing ones are
# made; the XML documents are rewritten and re-signed every time (cheap, and picks up a changed N).
# Environment: SWARMLOC_PKI_ORG (default swarmloc) is the O= of every subject; SWARMLOC_PKI_DAYS
# (default 365) the validity of participant certificates (CAs: 3650 days).
set -euo pipefail
set -f  # partition patterns like a* are literal text, never file globs

if [ $# -ne 2 ] || ! [[ "$2" =~ ^[0-9]+$ ]] || [ "$2" -lt 1 ]; then
  echo "usage: $0 OUT_DIR N   (N = number of agents, >= 1)" >&2
  exit 2
fi
command -v openssl >/dev/null || { echo "make-pki.sh: openssl is not installed" >&2; exit 2; }

out=$1
n=$2
org=${SWARMLOC_PKI_ORG:-swarmloc}
days=${SWARMLOC_PKI_DAYS:-365}
# Cyclone splits subject names on ',' '/' '|' '=' and does not trim: no spaces anywhere in subjects.
if [[ "$org" =~ [[:space:],/=|] ]]; then
  echo "make-pki.sh: SWARMLOC_PKI_ORG must not contain spaces or , / = |" >&2
  exit 2
fi

mkdir -p "$out/private"
chmod 700 "$out/private"
cd "$out"
umask 077

make_ca() {  # make_ca NAME  -> private/NAME.key, NAME.pem
  local name=$1
  if [ ! -s "private/$name.key" ]; then
    openssl ecparam -name prime256v1 -genkey -noout -out "private/$name.key"
    rm -f "$name.pem"
  fi
  if [ ! -s "$name.pem" ]; then
    openssl req -x509 -new -key "private/$name.key" -sha256 -days 3650 \
      -subj "/C=NL/O=$org/CN=swarmloc_$name" -out "$name.pem" 2>/dev/null
    chmod 644 "$name.pem"
  fi
}

subject_dn() { echo "CN=$1,O=$org,C=NL"; }  # permissions-document spelling of the subject

make_identity() {  # make_identity NAME  -> NAME/key.pem, NAME/cert.pem (signed by the identity CA)
  local name=$1
  mkdir -p "$name"
  chmod 755 "$name"
  if [ ! -s "$name/key.pem" ]; then
    openssl ecparam -name prime256v1 -genkey -noout -out "$name/key.pem"
    rm -f "$name/cert.pem"
  fi
  # Re-issue when missing or not signed by the current identity CA (e.g. after a CA rotation).
  if [ ! -s "$name/cert.pem" ] ||
    ! openssl verify -CAfile identity_ca.pem "$name/cert.pem" >/dev/null 2>&1; then
    openssl req -new -key "$name/key.pem" -subj "/C=NL/O=$org/CN=$name" -out "$name/cert.csr"
    openssl x509 -req -in "$name/cert.csr" -CA identity_ca.pem -CAkey private/identity_ca.key \
      -CAcreateserial -CAserial private/identity_ca.srl -sha256 -days "$days" -out "$name/cert.pem" 2>/dev/null
    rm -f "$name/cert.csr"
    chmod 644 "$name/cert.pem"
  fi
}

# One <allow_rule> granting publish or subscribe on TOPICS (space-separated) in PARTITIONS.
rule() {  # rule publish|subscribe "TOPICS" "PARTITIONS"
  local kind=$1 topic partition
  echo "      <allow_rule>"
  echo "        <domains><id_range><min>0</min><max>230</max></id_range></domains>"
  echo "        <$kind>"
  echo -n "          <topics>"
  for topic in $2; do echo -n "<topic>$topic</topic>"; done
  echo "</topics>"
  echo -n "          <partitions>"
  for partition in $3; do echo -n "<partition>$partition</partition>"; done
  echo "</partitions>"
  echo "        </$kind>"
  echo "      </allow_rule>"
}

# Topic and partition names: common/dds/src/endpoints.hpp (the manifest's: dds/manifest_topic.hpp).
families="swarmloc_state swarmloc_information swarmloc_consensus swarmloc_belief"
grant() {  # grant NAME ROLE [AGENT_ID]
  local name=$1 role=$2 id=${3:-}
  echo "    <grant name=\"${name}_grant\">"
  echo "      <subject_name>$(subject_dn "$name")</subject_name>"
  echo "      <validity><not_before>2020-01-01T00:00:00</not_before><not_after>2099-01-01T00:00:00</not_after></validity>"
  case $role in
    agent)  # "*.": every partition name starts with the run id (<run_id>.a3, docs/robustness.md)
      rule publish "$families" "*.a$id"           # its own inter-agent samples, only in its own partition
      rule publish "swarmloc_estimate" "*.est"
      rule subscribe "$families" "*.a* *.none"    # neighbours' partitions ("none": no neighbours)
      rule subscribe "swarmloc_measurements" "*.m$id"
      rule subscribe "swarmloc_control" "*.ctl"
      rule subscribe "swarmloc_manifest" "*.manifest.$id"  # only its own manifest (run --no-launch)
      ;;
    orchestrator)
      rule publish "swarmloc_manifest" "*.manifest.*"
      rule publish "swarmloc_measurements" "*.m*"
      rule publish "swarmloc_control" "*.ctl"
      rule subscribe "swarmloc_estimate" "*.est"
      ;;
    fusion)
      rule subscribe "swarmloc_measurements" "*.m*"
      rule subscribe "swarmloc_control" "*.ctl"
      rule publish "swarmloc_estimate" "*.est"
      ;;
  esac
  echo "      <default>DENY</default>"
  echo "    </grant>"
}

write_permissions() {  # write_permissions NAME ROLE [AGENT_ID] -> NAME/permissions.xml
  {
    echo '<?xml version="1.0" encoding="UTF-8"?>'
    echo '<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"'
    echo '     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">'
    echo '  <permissions>'
    grant "$@"
    echo '  </permissions>'
    echo '</dds>'
  } >"$1/permissions.xml"
}

sign() {  # sign FILE.xml -> FILE.p7s (S/MIME, clear-signed, by the permissions CA)
  openssl smime -sign -in "$1" -text -out "${1%.xml}.p7s" -signer permissions_ca.pem \
    -inkey private/permissions_ca.key
  chmod 644 "$1" "${1%.xml}.p7s"
}

make_ca identity_ca
make_ca permissions_ca

cat >governance.xml <<'XML'
<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance"
     xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>230</max></id_range></domains>
      <!-- only participants that authenticate with a certificate of the identity CA take part -->
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <!-- and only those with a valid permissions document signed by the permissions CA -->
      <enable_join_access_control>true</enable_join_access_control>
      <!-- discovery and liveliness traffic: encrypted; every RTPS message: signed (HMAC) -->
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>SIGN</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>swarmloc_*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <!-- submessages and payloads encrypted (AES-GCM) -->
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
XML
chmod 644 governance.xml
sign governance.xml

participants=()
for ((i = 0; i < n; ++i)); do participants+=("agent-$i"); done
participants+=(orchestrator fusion)
for name in "${participants[@]}"; do
  make_identity "$name"
  case $name in
    agent-*) write_permissions "$name" agent "${name#agent-}" ;;
    *) write_permissions "$name" "$name" ;;
  esac
  sign "$name/permissions.xml"
done
echo "make-pki.sh: $out: identity CA, permissions CA, governance, ${#participants[@]} participants (agent-0..agent-$((n - 1)), orchestrator, fusion)"
