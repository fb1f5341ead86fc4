 C408 Unnecessary `dict()` call (rewrite as a literal)
 I001 [*] Import block is un-sorted or un-formatted
 I001 [*] Import block is un-sorted or un-formatted
 I001 [*] Import block is un-sorted or un-formatted
 I001 [*] Import block is un-sorted or un-formatted
 RUF059 Unpacked variable `steps` is never used
 RUF100 [*] Unused `noqa` directive (non-enabled: `E731`)
 RUF100 [*] Unused `noqa` directive (non-enabled: `E731`)
Found 8 errors.
[*] 6 fixable with `--fix` (2 unsafe fixes available with `--fix --unsafe-fixes`).
