"""core/working_window.h's FFT cut for the Python benches and corpus tools (is_fft_friendly,
fast_side): the sides the service analyses an exemplar at."""


def fast_side(n, least):
    """The largest m <= n of the form 2^a 3^b 5^c 7^d, unless that is under `least` (an analysis'
    2r): then n."""
    for m in range(n, 1, -1):
        k = m
        for prime in (2, 3, 5, 7):
            while k % prime == 0:
                k //= prime
        if k == 1:
            return m if m >= least else n
    return n
