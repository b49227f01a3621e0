"""``core.messages``' time fields: a ``builtin_interfaces`` Time's ``sec`` is an ``int32``."""
import pytest
from gpr_kinematics.core.messages import NS_PER_S, duration_parts, time_parts
from gpr_kinematics.errors import InputError


def test_time_parts_at_the_ends_of_int32():
    assert time_parts((2**31 - 1) * NS_PER_S + 999_999_999) == (2**31 - 1, 999_999_999)
    assert time_parts(-(2**31) * NS_PER_S) == (-(2**31), 0)


def test_a_time_beyond_int32_sec_is_refused_not_wrapped():
    # 2038-01-19T03:14:08Z: sec 2^31 wrapped to -2^31 (1901) where it was serialised
    with pytest.raises(InputError) as e:
        time_parts(2**31 * NS_PER_S)
    assert str(e.value) == ("a time of 2147483648000000000 ns: sec = 2147483648 does not fit builtin_interfaces' "
                            'int32 sec; allowed: -2147483648 to 2147483647 s (up to 2038-01-19T03:14:07Z)')
    with pytest.raises(InputError, match='sec = -2147483649 does not fit'):
        time_parts(-(2**31) * NS_PER_S - 1)
    with pytest.raises(InputError, match='sec = 2147483648 does not fit'):
        duration_parts(2.0**31)
