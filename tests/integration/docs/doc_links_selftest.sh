#!/bin/sh
# The link check finds a broken link, a link to a heading that is not there (naming the file and
# line) and a log no reference page links to; it skips code and web addresses, and passes a tree
# whose links all resolve.
set -eu
check=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/docs/log"
printf '# r\n[fusion](docs/fusion.md) [web](https://example.org/x.md) `[code](nowhere.md)`\n' >"$tmp/README.md"
printf '# f\n[log](log/day.md#top) ![img](images/missing.png)\n```\n[in a block](nowhere.md)\n```\n' \
  >"$tmp/docs/fusion.md"
printf '# day\n[back](../fusion.md)\n## Top\n' >"$tmp/docs/log/day.md"
if out=$(python3 "$check" "$tmp" 2>&1); then
  echo "FAIL: a missing image passed: $out"; exit 1
fi
echo "$out" | grep -q "docs/fusion.md:2: link 'images/missing.png'" ||
  { echo "FAIL: the broken link is not named: $out"; exit 1; }
[ "$(echo "$out" | grep -c ': link ')" = 1 ] || { echo "FAIL: more than one reported: $out"; exit 1; }
mkdir -p "$tmp/docs/images" && : >"$tmp/docs/images/missing.png"
python3 "$check" "$tmp" || { echo "FAIL: a tree whose links resolve failed"; exit 1; }
printf '[gone](../fusion.md#no-such-heading) [here](day.md#top)\n' >>"$tmp/docs/log/day.md"
printf '[there](../fusion.md#f)\n' >>"$tmp/docs/log/day.md"
if out=$(python3 "$check" "$tmp" 2>&1); then
  echo "FAIL: a link to a missing heading passed: $out"; exit 1
fi
echo "$out" | grep -q "docs/log/day.md:4: link '../fusion.md#no-such-heading': no heading" ||
  { echo "FAIL: the missing heading is not named: $out"; exit 1; }
[ "$(echo "$out" | grep -c ': link ')" = 1 ] || { echo "FAIL: a good anchor was reported: $out"; exit 1; }
sed -i 's/#no-such-heading)/#f)/' "$tmp/docs/log/day.md"
python3 "$check" "$tmp" || { echo "FAIL: a tree whose links resolve failed"; exit 1; }
printf '# orphan\n' >"$tmp/docs/log/orphan.md"
if out=$(python3 "$check" "$tmp" 2>&1); then
  echo "FAIL: a log no reference links to passed: $out"; exit 1
fi
echo "$out" | grep -q "docs/log/orphan.md: no page outside docs/log links to this log" ||
  { echo "FAIL: the orphan log is not named: $out"; exit 1; }
echo PASS
